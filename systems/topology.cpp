#include "systems/topology.hpp"

#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>

namespace pt {

namespace {
// Rest data of one triangle: the inverse of [r1 − r0, r2 − r0] and the signed pattern area.
void rest_data_of(const std::vector<Vec2>& rest, const Tri& tri, Mat2& rest_inv, double& rest_area) {
  const Vec2& a = rest[tri[0]];
  Mat2 dm;
  dm.col(0) = rest[tri[1]] - a;
  dm.col(1) = rest[tri[2]] - a;
  const double det = dm.determinant();
  rest_area = 0.5 * det;
  rest_inv = det != 0 ? Mat2(dm.inverse()) : Mat2::Zero();
}
}  // namespace

void update_rest_data(const std::vector<Vec2>& rest, const std::vector<Tri>& tri,
                      std::vector<Mat2>& rest_inv, std::vector<double>& rest_area) {
  const size_t n = tri.size();
  rest_inv.resize(n);
  rest_area.resize(n);
  for (size_t t = 0; t < n; ++t) rest_data_of(rest, tri[t], rest_inv[t], rest_area[t]);
}

void lump_masses(const std::vector<Tri>& tri, const std::vector<double>& rest_area,
                 const Material& material, std::vector<double>& mass) {
  std::fill(mass.begin(), mass.end(), 0.0);
  const double areal_density = material.density * material.thickness;
  for (size_t t = 0; t < tri.size(); ++t)
    for (int32_t c : tri[t]) mass[c] += areal_density * rest_area[t] / 3.0;
}

namespace {
// Pieces by flood fill over neighbours, seeded in ascending triangle order (so a piece's number follows its
// lowest triangle). Returns the number of pieces.
int32_t flood_fill_pieces(const std::vector<std::array<int32_t, 3>>& neighbor, std::vector<int32_t>& piece) {
  const int32_t nt = static_cast<int32_t>(neighbor.size());
  piece.assign(nt, -1);
  std::vector<int32_t> stack;
  int32_t count = 0;
  for (int32_t s = 0; s < nt; ++s) {
    if (piece[s] >= 0) continue;
    piece[s] = count;
    stack.push_back(s);
    while (!stack.empty()) {
      const int32_t t = stack.back();
      stack.pop_back();
      for (int32_t n : neighbor[t])
        if (n >= 0 && piece[n] < 0) {
          piece[n] = count;
          stack.push_back(n);
        }
    }
    ++count;
  }
  return count;
}
}  // namespace

void build_topology(const std::vector<Tri>& tri, int32_t vertex_count, Topology& topo,
                    std::vector<int32_t>& piece) {
  const int32_t nt = static_cast<int32_t>(tri.size());
  // Vertex → triangle CSR, ascending triangle ids per vertex.
  topo.vt_offset.assign(vertex_count + 1, 0);
  for (const Tri& t : tri)
    for (int32_t c : t) ++topo.vt_offset[c + 1];
  for (int32_t i = 0; i < vertex_count; ++i) topo.vt_offset[i + 1] += topo.vt_offset[i];
  topo.vt_tri.assign(topo.vt_offset[vertex_count], -1);
  {
    std::vector<int32_t> fill(topo.vt_offset.begin(), topo.vt_offset.end() - 1);
    for (int32_t t = 0; t < nt; ++t)
      for (int32_t c : tri[t]) topo.vt_tri[fill[c]++] = t;
  }
  // Half-edges in (lo, hi, t, i) order pair up neighbours. Bucketed by their lower vertex (counting sort,
  // filled in (t, i) order) and each short bucket sorted by hi: the order of one global sort, in linear time
  // but for the buckets — this runs after every cut (remeshing), so it is on the tearing path.
  struct HalfEdge {
    int32_t lo, hi, t, i;
  };
  std::vector<int32_t> bucket(vertex_count + 1, 0);
  for (const Tri& t : tri)
    for (int32_t i = 0; i < 3; ++i) ++bucket[std::min(t[i], t[(i + 1) % 3]) + 1];
  for (int32_t v = 0; v < vertex_count; ++v) bucket[v + 1] += bucket[v];
  std::vector<HalfEdge> he(3 * static_cast<size_t>(nt));
  {
    std::vector<int32_t> next(bucket.begin(), bucket.end() - 1);
    for (int32_t t = 0; t < nt; ++t)
      for (int32_t i = 0; i < 3; ++i) {
        const int32_t a = tri[t][i], b = tri[t][(i + 1) % 3];
        he[next[std::min(a, b)]++] = {std::min(a, b), std::max(a, b), t, i};
      }
  }
  for (int32_t v = 0; v < vertex_count; ++v)  // insertion sort, stable: equal hi keep their (t, i) order
    for (int32_t k = bucket[v] + 1; k < bucket[v + 1]; ++k) {
      const HalfEdge e = he[k];
      int32_t j = k;
      for (; j > bucket[v] && he[j - 1].hi > e.hi; --j) he[j] = he[j - 1];
      he[j] = e;
    }
  topo.neighbor.assign(nt, {-1, -1, -1});
  topo.hinges.clear();
  for (size_t k = 0; k < he.size();) {
    size_t m = k + 1;
    while (m < he.size() && he[m].lo == he[k].lo && he[m].hi == he[k].hi) ++m;
    if (m - k == 2) {
      const HalfEdge& e0 = he[k];
      const HalfEdge& e1 = he[k + 1];
      topo.neighbor[e0.t][e0.i] = e1.t;
      topo.neighbor[e1.t][e1.i] = e0.t;
      // Orient the hinge so v0→v1 is counter-clockwise in the triangle holding v2.
      const int32_t a0 = tri[e0.t][e0.i], b0 = tri[e0.t][(e0.i + 1) % 3];
      const int32_t opp0 = tri[e0.t][(e0.i + 2) % 3];
      const int32_t opp1 = tri[e1.t][(e1.i + 2) % 3];
      topo.hinges.push_back(Hinge{{a0, b0, opp0, opp1}});
    }
    k = m;  // edges shared by more than two triangles stay unpaired; check_mesh_invariants reports them
  }
  // topo.hinges come out sorted by (min(v0, v1), max(v0, v1)): the half-edges were in (lo, hi) order.
  topo.boundary_next.assign(vertex_count, -1);
  topo.boundary_prev.assign(vertex_count, -1);
  for (int32_t t = 0; t < nt; ++t)
    for (int32_t i = 0; i < 3; ++i)
      if (topo.neighbor[t][i] < 0) {
        const int32_t a = tri[t][i], b = tri[t][(i + 1) % 3];
        topo.boundary_next[a] = b;
        topo.boundary_prev[b] = a;
      }
  topo.piece_count = flood_fill_pieces(topo.neighbor, piece);
}

double interior_pattern_angle(const Topology& topo, const std::vector<Vec2>& rest, int32_t v) {
  const int32_t next = topo.boundary_next[v], prev = topo.boundary_prev[v];
  if (next < 0 || prev < 0) return 0.0;
  const Vec2 a = rest[next] - rest[v];
  const Vec2 b = rest[prev] - rest[v];
  // Counter-clockwise angle from (next − v) to (prev − v): the interior lies on the left of the boundary.
  double angle = std::atan2(a.x() * b.y() - a.y() * b.x(), a.dot(b));
  if (angle <= 0) angle += 2 * std::numbers::pi;
  return angle;
}

void update_boundary_flags(const Topology& topo, const std::vector<Vec2>& rest, double inward_tolerance,
                           std::vector<uint8_t>& flags) {
  const int32_t n = static_cast<int32_t>(flags.size());
  for (int32_t v = 0; v < n; ++v) {
    uint8_t f = flags[v] & ~(kBoundary | kInward);
    if (topo.boundary_next[v] >= 0) {
      f |= kBoundary;
      if (interior_pattern_angle(topo, rest, v) > std::numbers::pi + inward_tolerance) f |= kInward;
    }
    flags[v] = f;
  }
}

void refresh_after_topology_change(Sheet& sheet) {
  Vertices& V = sheet.verts;
  Triangles& T = sheet.tris;
  const int32_t nt = T.size();
  T.corner_force.resize(nt, {Vec3::Zero(), Vec3::Zero(), Vec3::Zero()});
  T.region.resize(nt, -1);
  T.side.resize(nt, 0);
  update_rest_data(V.rest, T.tri, T.rest_inv, T.rest_area);
  lump_masses(T.tri, T.rest_area, sheet.material, V.mass);
  build_topology(T.tri, V.size(), sheet.topo, T.piece);
  update_boundary_flags(sheet.topo, V.rest, 0.05, V.flags);
  sheet.topology_version += 1;
  sheet.topo.version = sheet.topology_version;
}

namespace {
// Buffers of the local refresh, kept per thread between cuts: a cut runs every few frames and its refresh
// would otherwise spend more on allocation than on the change itself (small sheets), or fault in fresh
// pages for the fan and hinge arrays (big ones).
struct LocalRefreshScratch {
  std::vector<char> mark;
  std::vector<int32_t> fan_flat, fan_start, around, offset, vt;
  std::vector<Hinge> merged;
};
}  // namespace

void refresh_after_local_change(const LocalTopologyChange& change, Sheet& sheet) {
  Vertices& V = sheet.verts;
  Triangles& T = sheet.tris;
  Topology& topo = sheet.topo;
  const int32_t nv = V.size(), nt = T.size();
  const int32_t nv_before = static_cast<int32_t>(topo.vt_offset.size()) - 1;
  if (topo.version != sheet.topology_version || nv_before < 0 ||
      static_cast<int32_t>(topo.boundary_next.size()) != nv_before) {
    refresh_after_topology_change(sheet);
    return;
  }
  const std::vector<int32_t>& A = change.vertices;  // affected vertices, ascending
  thread_local LocalRefreshScratch scratch;
  std::vector<char>& mark = scratch.mark;  // one byte per vertex: no search per hinge
  mark.assign(std::max(nv, nv_before), 0);
  for (int32_t v : A) mark[v] = 1;
  auto contains = [](const Tri& t, int32_t v) { return t[0] == v || t[1] == v || t[2] == v; };
  // A triangle id of the topology before the change → its id now (−1: removed).
  auto tri_now = [&](int32_t t) {
    if (std::binary_search(change.dead_triangles.begin(), change.dead_triangles.end(), t)) return -1;
    for (const auto& m : change.moved_triangles)
      if (m.first == t) return m.second;
    return t;
  };

  T.corner_force.resize(nt, {Vec3::Zero(), Vec3::Zero(), Vec3::Zero()});
  T.region.resize(nt, -1);
  T.side.resize(nt, 0);
  T.rest_inv.resize(nt);
  T.rest_area.resize(nt);
  for (int32_t t : change.triangles) rest_data_of(V.rest, T.tri[t], T.rest_inv[t], T.rest_area[t]);

  // Fans: the affected vertices' from their old fan and the changed triangles; runs of unaffected vertices
  // copied as blocks (their fans hold no changed, moved or removed triangle).
  std::vector<int32_t>& fan_flat = scratch.fan_flat;  // fan of A[k] at [fan_start[k], fan_start[k + 1])
  std::vector<int32_t>& fan_start = scratch.fan_start;
  fan_flat.clear();
  fan_start.assign(1, 0);
  for (const int32_t v : A) {
    const auto first = static_cast<std::ptrdiff_t>(fan_flat.size());
    if (v < nv_before)
      for (int32_t q = topo.vt_offset[v]; q < topo.vt_offset[v + 1]; ++q)
        if (const int32_t t = tri_now(topo.vt_tri[q]); t >= 0 && t < nt && contains(T.tri[t], v)) fan_flat.push_back(t);
    for (int32_t t : change.triangles)
      if (contains(T.tri[t], v)) fan_flat.push_back(t);
    std::sort(fan_flat.begin() + first, fan_flat.end());
    fan_flat.erase(std::unique(fan_flat.begin() + first, fan_flat.end()), fan_flat.end());
    fan_start.push_back(static_cast<int32_t>(fan_flat.size()));
  }
  std::vector<int32_t>& offset = scratch.offset;
  std::vector<int32_t>& vt = scratch.vt;
  offset.assign(nv + 1, 0);
  vt.clear();
  vt.reserve(topo.vt_tri.size() + 3 * change.triangles.size());
  {
    int32_t v = 0;
    size_t k = 0;
    while (v < nv) {
      const int32_t run_end = k < A.size() ? std::min(A[k], nv) : nv;  // [v, run_end) unaffected
      if (run_end > v) {
        const int32_t first = topo.vt_offset[v], last = topo.vt_offset[run_end];
        const int32_t delta = static_cast<int32_t>(vt.size()) - first;
        vt.insert(vt.end(), topo.vt_tri.begin() + first, topo.vt_tri.begin() + last);
        for (int32_t u = v; u < run_end; ++u) offset[u + 1] = topo.vt_offset[u + 1] + delta;
        v = run_end;
      }
      if (k < A.size() && v == A[k]) {
        vt.insert(vt.end(), fan_flat.begin() + fan_start[k], fan_flat.begin() + fan_start[k + 1]);
        offset[v + 1] = static_cast<int32_t>(vt.size());
        ++v;
        ++k;
      }
    }
  }
  // Copied, not swapped: the sheet keeps its own buffers (their capacity then depends only on its history,
  // not on which thread's scratch it met, so batch memory figures are the same at any thread count).
  topo.vt_offset.assign(offset.begin(), offset.end());
  topo.vt_tri.assign(vt.begin(), vt.end());
  auto fan_begin = [&](int32_t v) { return topo.vt_tri.begin() + topo.vt_offset[v]; };
  auto fan_end = [&](int32_t v) { return topo.vt_tri.begin() + topo.vt_offset[v + 1]; };

  // Neighbours of every triangle around an affected vertex (an edge pairs exactly two triangles, as in
  // build_topology; more stay unpaired).
  topo.neighbor.resize(nt, {-1, -1, -1});
  std::vector<int32_t>& around = scratch.around;
  around.clear();
  for (int32_t v : A) around.insert(around.end(), fan_begin(v), fan_end(v));
  std::sort(around.begin(), around.end());
  around.erase(std::unique(around.begin(), around.end()), around.end());
  for (int32_t t : around)
    for (int32_t i = 0; i < 3; ++i) {
      const int32_t a = T.tri[t][i], b = T.tri[t][(i + 1) % 3];
      int32_t other = -1, count = 0;
      for (auto it = fan_begin(a); it != fan_end(a); ++it)
        if (contains(T.tri[*it], b)) {
          ++count;
          if (*it != t) other = *it;
        }
      topo.neighbor[t][i] = count == 2 ? other : -1;
    }

  // Hinges: the old ones away from the change kept in order, the ones on edges at an affected vertex
  // rebuilt (oriented from the lower triangle, as build_topology does), merged by (min, max) of the edge.
  struct Keyed {
    int32_t lo, hi;
    Hinge h;
  };
  std::vector<Keyed> fresh;
  for (int32_t a : A)
    for (auto it = fan_begin(a); it != fan_end(a); ++it) {
      const int32_t t0 = *it;
      for (int32_t i = 0; i < 3; ++i) {
        const int32_t x = T.tri[t0][i], y = T.tri[t0][(i + 1) % 3];
        if (x != a && y != a) continue;
        const int32_t t1 = topo.neighbor[t0][i];
        if (t1 < 0 || t1 < t0) continue;  // boundary, or listed from the lower triangle
        int32_t j = 0;
        while (!(T.tri[t1][j] == y && T.tri[t1][(j + 1) % 3] == x) && !(T.tri[t1][j] == x && T.tri[t1][(j + 1) % 3] == y)) ++j;
        fresh.push_back({std::min(x, y), std::max(x, y), Hinge{{x, y, T.tri[t0][(i + 2) % 3], T.tri[t1][(j + 2) % 3]}}});
      }
    }
  std::sort(fresh.begin(), fresh.end(), [](const Keyed& p, const Keyed& q) { return p.lo != q.lo ? p.lo < q.lo : p.hi < q.hi; });
  fresh.erase(std::unique(fresh.begin(), fresh.end(), [](const Keyed& p, const Keyed& q) { return p.lo == q.lo && p.hi == q.hi; }),
              fresh.end());
  {
    // Kept hinges are copied in runs (a memory-speed copy); a run ends at a dropped hinge or where a fresh
    // one goes in.
    std::vector<Hinge>& out = scratch.merged;
    out.clear();
    out.reserve(topo.hinges.size() + fresh.size());
    const std::vector<Hinge>& old = topo.hinges;
    const size_t n_old = old.size();
    size_t f = 0, run = 0;
    for (size_t k = 0; k < n_old; ++k) {
      const Hinge& h = old[k];
      const int32_t lo = std::min(h.v[0], h.v[1]), hi = std::max(h.v[0], h.v[1]);
      const bool keep = hi < nv && !mark[lo] && !mark[hi];
      const bool insert_before = keep && f < fresh.size() && (fresh[f].lo < lo || (fresh[f].lo == lo && fresh[f].hi < hi));
      if (!keep || insert_before) {
        out.insert(out.end(), old.begin() + run, old.begin() + k);
        run = keep ? k : k + 1;
        while (insert_before && f < fresh.size() && (fresh[f].lo < lo || (fresh[f].lo == lo && fresh[f].hi < hi)))
          out.push_back(fresh[f++].h);
      }
    }
    out.insert(out.end(), old.begin() + run, old.end());
    while (f < fresh.size()) out.push_back(fresh[f++].h);
    topo.hinges.assign(out.begin(), out.end());
  }

  // Boundary links, masses and flags of the affected vertices (in fan order: the same last-wins and
  // summation order as the full refresh).
  topo.boundary_next.resize(nv, -1);
  topo.boundary_prev.resize(nv, -1);
  const double areal_density = sheet.material.density * sheet.material.thickness;
  for (int32_t v : A) {
    int32_t next = -1, prev = -1;
    double mass = 0.0;
    for (auto it = fan_begin(v); it != fan_end(v); ++it) {
      const int32_t t = *it;
      const int32_t i = T.tri[t][0] == v ? 0 : (T.tri[t][1] == v ? 1 : 2);
      if (topo.neighbor[t][i] < 0) next = T.tri[t][(i + 1) % 3];
      const int32_t j = (i + 2) % 3;
      if (topo.neighbor[t][j] < 0) prev = T.tri[t][j];
      mass += areal_density * T.rest_area[t] / 3.0;
    }
    topo.boundary_next[v] = next;
    topo.boundary_prev[v] = prev;
    V.mass[v] = mass;
  }
  for (int32_t v : A) {
    uint8_t f = V.flags[v] & ~(kBoundary | kInward);
    if (topo.boundary_next[v] >= 0) {
      f |= kBoundary;
      if (interior_pattern_angle(topo, V.rest, v) > std::numbers::pi + 0.05) f |= kInward;
    }
    V.flags[v] = f;
  }

  // Pieces: a cut that reached the boundary may part the sheet (flood fill again); otherwise the changed
  // triangles kept their parent's piece and only the numbering by lowest triangle may need restoring.
  if (change.pieces_may_split) {
    topo.piece_count = flood_fill_pieces(topo.neighbor, T.piece);
  } else if (topo.piece_count > 1) {
    std::vector<int32_t> order(topo.piece_count, -1);  // old piece id → new, by first appearance
    int32_t next_id = 0;
    for (int32_t t = 0; t < nt && next_id < topo.piece_count; ++t)
      if (order[T.piece[t]] < 0) order[T.piece[t]] = next_id++;
    bool same = true;
    for (int32_t p = 0; p < topo.piece_count; ++p) same = same && order[p] == p;
    if (!same)
      for (int32_t& p : T.piece) p = order[p];
  }

  sheet.topology_version += 1;
  topo.version = sheet.topology_version;
}

double total_rest_area(const Triangles& tris) {
  double a = 0;
  for (double x : tris.rest_area) a += x;
  return a;
}

std::string check_mesh_invariants(const Sheet& sheet, double expected_area) {
  const Vertices& V = sheet.verts;
  const Triangles& T = sheet.tris;
  const int32_t nv = V.size(), nt = T.size();
  std::ostringstream err;
  if (static_cast<int32_t>(V.v.size()) != nv || static_cast<int32_t>(V.rest.size()) != nv ||
      static_cast<int32_t>(V.mass.size()) != nv || static_cast<int32_t>(V.flags.size()) != nv ||
      static_cast<int32_t>(V.force.size()) != nv || static_cast<int32_t>(V.tear.size()) != nv)
    return "vertex arrays differ in length";
  if (static_cast<int32_t>(T.rest_inv.size()) != nt || static_cast<int32_t>(T.rest_area.size()) != nt ||
      static_cast<int32_t>(T.corner_force.size()) != nt || static_cast<int32_t>(T.piece.size()) != nt)
    return "triangle arrays differ in length";
  for (int32_t t = 0; t < nt; ++t) {
    for (int32_t c : T.tri[t])
      if (c < 0 || c >= nv) {
        err << "triangle " << t << " has invalid corner " << c;
        return err.str();
      }
    const Vec2 a = V.rest[T.tri[t][0]], b = V.rest[T.tri[t][1]], c = V.rest[T.tri[t][2]];
    const double area = 0.5 * ((b - a).x() * (c - a).y() - (b - a).y() * (c - a).x());
    if (!(area > 0)) {
      err << "triangle " << t << " is not counter-clockwise (pattern area " << area << ")";
      return err.str();
    }
  }
  // Edge manifoldness.
  std::vector<std::pair<int64_t, int32_t>> edges;
  edges.reserve(3 * nt);
  for (int32_t t = 0; t < nt; ++t)
    for (int32_t i = 0; i < 3; ++i) {
      const int64_t a = T.tri[t][i], b = T.tri[t][(i + 1) % 3];
      edges.push_back({std::min(a, b) * nv + std::max(a, b), t});
    }
  std::sort(edges.begin(), edges.end());
  for (size_t k = 0; k + 2 < edges.size() + 0 && k + 2 < edges.size(); ++k)
    if (edges[k].first == edges[k + 2].first) {
      err << "edge (" << edges[k].first / nv << "," << edges[k].first % nv << ") shared by more than two triangles";
      return err.str();
    }
  for (size_t k = 0; k + 1 < edges.size(); ++k)
    if (edges[k].first == edges[k + 1].first) {
      // Same orientation twice means a flipped neighbour.
      const int32_t t0 = edges[k].second, t1 = edges[k + 1].second;
      const int32_t a = static_cast<int32_t>(edges[k].first / nv);
      auto next_of = [&](int32_t t, int32_t v) {
        for (int32_t i = 0; i < 3; ++i)
          if (T.tri[t][i] == v) return T.tri[t][(i + 1) % 3];
        return -1;
      };
      if (next_of(t0, a) == next_of(t1, a) && next_of(t0, a) != -1) {
        err << "triangles " << t0 << " and " << t1 << " traverse a shared edge in the same direction";
        return err.str();
      }
    }
  // Fan connectivity: the triangles around each vertex form one edge-connected fan.
  Topology topo;
  std::vector<int32_t> piece;
  build_topology(T.tri, nv, topo, piece);
  for (int32_t v = 0; v < nv; ++v) {
    const int32_t b = topo.vt_offset[v], e = topo.vt_offset[v + 1];
    if (b == e) {
      err << "vertex " << v << " belongs to no triangle";
      return err.str();
    }
    std::vector<int32_t> fan(topo.vt_tri.begin() + b, topo.vt_tri.begin() + e);
    std::vector<char> seen(fan.size(), 0);
    std::vector<int32_t> stack{0};
    seen[0] = 1;
    size_t reached = 1;
    while (!stack.empty()) {
      const int32_t k = stack.back();
      stack.pop_back();
      for (int32_t n : topo.neighbor[fan[k]]) {
        if (n < 0) continue;
        auto it = std::find(fan.begin(), fan.end(), n);
        if (it == fan.end()) continue;
        const size_t j = static_cast<size_t>(it - fan.begin());
        if (!seen[j]) {
          seen[j] = 1;
          ++reached;
          stack.push_back(static_cast<int32_t>(j));
        }
      }
    }
    if (reached != fan.size()) {
      err << "vertex " << v << " has a disconnected triangle fan (bow-tie)";
      return err.str();
    }
  }
  if (expected_area >= 0) {
    double area = 0;
    for (int32_t t = 0; t < nt; ++t) {
      const Vec2 a = V.rest[T.tri[t][0]], b = V.rest[T.tri[t][1]], c = V.rest[T.tri[t][2]];
      area += 0.5 * ((b - a).x() * (c - a).y() - (b - a).y() * (c - a).x());
    }
    if (std::abs(area - expected_area) > 1e-9 * std::max(1.0, expected_area) + 1e-12) {
      err << "total pattern area " << area << " differs from " << expected_area;
      return err.str();
    }
  }
  // Derived data kept up to date by the local refresh after a cut must equal a full rebuild, bit for bit.
  if (sheet.topo.version == sheet.topology_version) {
    const Topology& cur = sheet.topo;
    const char* what = nullptr;
    if (cur.vt_offset != topo.vt_offset || cur.vt_tri != topo.vt_tri) what = "vertex fans";
    else if (cur.neighbor != topo.neighbor) what = "triangle neighbours";
    else if (cur.boundary_next != topo.boundary_next || cur.boundary_prev != topo.boundary_prev) what = "boundary links";
    else if (cur.piece_count != topo.piece_count || T.piece != piece) what = "pieces";
    else if (cur.hinges.size() != topo.hinges.size()) what = "hinge count";
    for (size_t h = 0; !what && h < topo.hinges.size(); ++h)
      if (cur.hinges[h].v != topo.hinges[h].v) what = "hinges";
    if (!what) {
      std::vector<Mat2> inv;
      std::vector<double> area;
      update_rest_data(V.rest, T.tri, inv, area);
      std::vector<double> mass(nv, 0.0);
      lump_masses(T.tri, area, sheet.material, mass);
      std::vector<uint8_t> flags = V.flags;
      update_boundary_flags(topo, V.rest, 0.05, flags);
      if (area != T.rest_area) what = "rest areas";
      for (int32_t t = 0; !what && t < nt; ++t)
        if (inv[t] != T.rest_inv[t]) what = "rest inverses";
      if (!what && mass != V.mass) what = "lumped masses";
      if (!what && flags != V.flags) what = "boundary flags";
    }
    if (what) return std::string("the topology's ") + what + " differ from a full rebuild";
  }
  return {};
}

}  // namespace pt
