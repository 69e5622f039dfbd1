#include "systems/common/topology.hpp"

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
  // Vertex → triangle fans, ascending triangle ids per vertex, each with kFanSlack spare entries.
  topo.fans.assign(vertex_count, Topology::FanRoom{});
  for (const Tri& t : tri)
    for (int32_t c : t) ++topo.fans[c].count;
  int32_t pool = 0;
  for (Topology::FanRoom& f : topo.fans) {
    f.offset = pool;
    f.capacity = f.count + kFanSlack;
    pool += f.capacity;
  }
  topo.vt_tri.assign(pool, -1);
  topo.vt_unused = 0;
  {
    std::vector<int32_t> fill(vertex_count);
    for (int32_t i = 0; i < vertex_count; ++i) fill[i] = topo.fans[i].offset;
    for (int32_t t = 0; t < nt; ++t)
      for (int32_t c : tri[t]) topo.vt_tri[fill[c]++] = t;
  }
  // Half-edges in (lo, hi, t, i) order pair up neighbours. Bucketed by their lower vertex (counting sort,
  // filled in (t, i) order) and each short bucket sorted by hi: the order of one global sort, in linear time
  // but for the buckets (this runs after meshing and each finger's vertex insertion).
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
  topo.edge_hinge.assign(nt, {-1, -1, -1});
  topo.hinges.clear();
  for (size_t k = 0; k < he.size();) {
    size_t m = k + 1;
    while (m < he.size() && he[m].lo == he[k].lo && he[m].hi == he[k].hi) ++m;
    if (m - k == 2) {
      const HalfEdge& e0 = he[k];
      const HalfEdge& e1 = he[k + 1];
      topo.neighbor[e0.t][e0.i] = e1.t;
      topo.neighbor[e1.t][e1.i] = e0.t;
      topo.edge_hinge[e0.t][e0.i] = static_cast<int32_t>(topo.hinges.size());
      topo.edge_hinge[e1.t][e1.i] = static_cast<int32_t>(topo.hinges.size());
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
  topo.boundary_vertices.clear();
  for (int32_t v = 0; v < vertex_count; ++v)
    if (topo.boundary_next[v] >= 0) topo.boundary_vertices.push_back(v);
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
// would otherwise spend more on allocation than on the change itself.
struct LocalRefreshScratch {
  std::vector<uint32_t> stamp;  // stamp[v] == generation: v is affected (no search per edge)
  // tri_stamp[t] == generation: old triangle t was rewritten, removed or moved; tri_now[t] is its id now
  // (−1 removed; itself when rewritten in place).
  std::vector<uint32_t> tri_stamp;
  std::vector<int32_t> tri_now;
  uint32_t generation = 0;
  std::vector<int32_t> fan, around, dropped, boundary;
  struct HalfEdge {
    int32_t lo, hi, t, i;
    int32_t first;  // the first half-edge listed on the same edge (itself if it is the first)
    int32_t twin;   // on the first: the second half-edge of its edge, −1 if none yet
    int32_t count;  // on the first: how many half-edges the edge has
  };
  std::vector<HalfEdge> half_edges;
  std::vector<int32_t> edge_table;  // open addressing on (lo, hi) → first half-edge, −1 empty
};

// Writes `fan` as vertex v's fan: in place when it fits its room, else at the end of the pool.
void store_fan(int32_t v, const std::vector<int32_t>& fan, Topology& topo) {
  Topology::FanRoom& room = topo.fans[v];
  const int32_t count = static_cast<int32_t>(fan.size());
  if (count > room.capacity) {
    topo.vt_unused += room.capacity;
    room.offset = static_cast<int32_t>(topo.vt_tri.size());
    room.capacity = count + kFanSlack;
    topo.vt_tri.resize(topo.vt_tri.size() + room.capacity, -1);
  }
  std::copy(fan.begin(), fan.end(), topo.vt_tri.begin() + room.offset);
  room.count = count;
}

// Index of the edge (a, b), either way round, in triangle t; −1 if t has no such edge.
int edge_index(const Tri& t, int32_t a, int32_t b) {
  for (int i = 0; i < 3; ++i) {
    const int32_t x = t[i], y = t[(i + 1) % 3];
    if ((x == a && y == b) || (x == b && y == a)) return i;
  }
  return -1;
}
}  // namespace

void compact_fans(Topology& topo) {
  std::vector<int32_t> pool;
  pool.reserve(topo.vt_tri.size() - topo.vt_unused);
  for (Topology::FanRoom& room : topo.fans) {
    const int32_t first = room.offset;
    room.offset = static_cast<int32_t>(pool.size());
    pool.insert(pool.end(), topo.vt_tri.begin() + first, topo.vt_tri.begin() + first + room.capacity);
  }
  topo.vt_tri.assign(pool.begin(), pool.end());
  topo.vt_unused = 0;
}

namespace {
// Sheet sizes around a local change: now (the arrays') and before (the topology's).
struct ChangeSizes {
  int32_t nv, nt;
  int32_t nv_before, nt_before;
};

bool contains(const Tri& t, int32_t v) { return t[0] == v || t[1] == v || t[2] == v; }

// The stamps of the current change: v is an affected vertex; old triangle t was rewritten, removed or moved.
bool is_affected(const LocalRefreshScratch& scratch, int32_t v) { return scratch.stamp[v] == scratch.generation; }
bool was_rewritten(const LocalRefreshScratch& scratch, int32_t t) {
  return scratch.tri_stamp[t] == scratch.generation;
}
// A triangle id of the topology before the change → its id now (−1: removed).
int32_t old_tri_now(const LocalRefreshScratch& scratch, int32_t t) {
  return was_rewritten(scratch, t) ? scratch.tri_now[t] : t;
}

// Stamps the affected vertices and the old triangles the change touched, under a new generation.
void stamp_change(const LocalTopologyChange& change, const ChangeSizes& n, LocalRefreshScratch& scratch) {
  const int32_t nv = n.nv, nv_before = n.nv_before, nt_before = n.nt_before;
  const std::vector<int32_t>& A = change.vertices;  // affected vertices, ascending
  const size_t vertex_ids = static_cast<size_t>(std::max(nv, nv_before));
  if (scratch.stamp.size() < vertex_ids) scratch.stamp.resize(vertex_ids, 0);
  if (scratch.tri_stamp.size() < static_cast<size_t>(nt_before)) {
    scratch.tri_stamp.resize(nt_before, 0);
    scratch.tri_now.resize(nt_before, -1);
  }
  if (++scratch.generation == 0) {  // wrapped: forget every old stamp
    std::fill(scratch.stamp.begin(), scratch.stamp.end(), 0);
    std::fill(scratch.tri_stamp.begin(), scratch.tri_stamp.end(), 0);
    scratch.generation = 1;
  }
  const uint32_t generation = scratch.generation;
  for (int32_t v : A) scratch.stamp[v] = generation;
  // Old triangles the change touched: rewritten in place (their slot is a changed triangle), moved, removed.
  auto mark_old = [&](int32_t t, int32_t now) {
    if (t < nt_before) {
      scratch.tri_stamp[t] = generation;
      scratch.tri_now[t] = now;
    }
  };
  for (int32_t t : change.triangles) mark_old(t, t);
  for (const auto& m : change.moved_triangles) mark_old(m.first, m.second);
  for (int32_t t : change.dead_triangles) mark_old(t, -1);
}

// Hinges the change removes: every hinge at an affected vertex, and at the ids past the new end (removed
// vertices, or the old ids of the ones moved into their slots), found through the old fans and edges. An
// old triangle the change left alone still has its corners; only for the few it rewrote, removed or moved
// is the hinge's own edge read. Into scratch.dropped, ascending and unique.
void collect_dropped_hinges(const LocalTopologyChange& change, const ChangeSizes& n, const Topology& topo,
                            const Triangles& T, LocalRefreshScratch& scratch) {
  const std::vector<int32_t>& A = change.vertices;
  const int32_t nv = n.nv, nv_before = n.nv_before;
  auto rewritten = [&](int32_t t) { return was_rewritten(scratch, t); };
  std::vector<int32_t>& dropped = scratch.dropped;
  dropped.clear();
  auto drop_hinges_at = [&](int32_t v) {
    for (int32_t t : topo.fan(v)) {
      const bool same = !rewritten(t);
      for (int32_t i = 0; i < 3; ++i) {
        const int32_t h = topo.edge_hinge[t][i];
        if (h < 0) continue;
        const bool at_v = same ? (T.tri[t][i] == v || T.tri[t][(i + 1) % 3] == v)
                               : (topo.hinges[h].v[0] == v || topo.hinges[h].v[1] == v);
        if (at_v) dropped.push_back(h);
      }
    }
  };
  for (int32_t v : A)
    if (v < nv_before) drop_hinges_at(v);
  for (int32_t v = nv; v < nv_before; ++v) drop_hinges_at(v);
  std::sort(dropped.begin(), dropped.end());
  dropped.erase(std::unique(dropped.begin(), dropped.end()), dropped.end());
}

// Fans: an affected vertex's fan is its old fan (renamed, without the removed triangles and those that let
// go of it) plus the changed triangles that hold it. The others hold no changed, moved or removed triangle.
void refresh_affected_fans(const LocalTopologyChange& change, const ChangeSizes& n, const Triangles& T,
                           LocalRefreshScratch& scratch, Topology& topo) {
  const std::vector<int32_t>& A = change.vertices;
  const int32_t nv = n.nv, nt = n.nt, nv_before = n.nv_before;
  auto tri_now = [&](int32_t t) { return old_tri_now(scratch, t); };
  for (int32_t v = nv; v < nv_before; ++v) topo.vt_unused += topo.fans[v].capacity;
  topo.fans.resize(nv);
  std::vector<int32_t>& fan = scratch.fan;
  for (const int32_t v : A) {
    fan.clear();
    if (v < nv_before)
      for (int32_t old : topo.fan(v))
        if (const int32_t t = tri_now(old); t >= 0 && t < nt && contains(T.tri[t], v)) fan.push_back(t);
    for (int32_t t : change.triangles)
      if (contains(T.tri[t], v)) fan.push_back(t);
    std::sort(fan.begin(), fan.end());
    fan.erase(std::unique(fan.begin(), fan.end()), fan.end());
    store_fan(v, fan, topo);
  }
  if (topo.vt_unused > 64 && 2 * static_cast<size_t>(topo.vt_unused) > topo.vt_tri.size()) compact_fans(topo);
}

// The half-edges at an affected vertex of the triangles around one (scratch.half_edges), each linked to the
// first on its edge, that first to its twin and its count.
void pair_half_edges_at_affected(const std::vector<int32_t>& A, const Topology& topo, const Triangles& T,
                                 LocalRefreshScratch& scratch) {
  auto affected = [&](int32_t v) { return is_affected(scratch, v); };
  std::vector<int32_t>& around = scratch.around;
  around.clear();
  for (int32_t v : A) around.insert(around.end(), topo.fan(v).begin(), topo.fan(v).end());
  std::sort(around.begin(), around.end());
  around.erase(std::unique(around.begin(), around.end()), around.end());
  auto& he = scratch.half_edges;
  he.clear();
  for (int32_t t : around)
    for (int32_t i = 0; i < 3; ++i) {
      const int32_t a = T.tri[t][i], b = T.tri[t][(i + 1) % 3];
      if (affected(a) || affected(b)) he.push_back({std::min(a, b), std::max(a, b), t, i, -1, -1, 0});
    }
  // Paired through a small hash table on the edge rather than a sort (a cut's refresh sorted ~60 of them
  // with unpredictable comparisons). Listed in ascending triangle order, so an edge's first half-edge is on
  // its lower triangle, which orients the hinge as build_topology does.
  std::vector<int32_t>& table = scratch.edge_table;
  size_t mask = 15;
  while (mask + 1 < 2 * he.size()) mask = 2 * mask + 1;
  table.assign(mask + 1, -1);
  for (int32_t k = 0; k < static_cast<int32_t>(he.size()); ++k) {
    size_t h = (static_cast<size_t>(he[k].lo) * 0x9E3779B1u + static_cast<size_t>(he[k].hi)) & mask;
    while (table[h] >= 0 && (he[table[h]].lo != he[k].lo || he[table[h]].hi != he[k].hi)) h = (h + 1) & mask;
    if (table[h] < 0) table[h] = k;
    const int32_t first = table[h];
    he[k].first = first;
    if (++he[first].count == 2) he[first].twin = k;
  }
}

// Sets the neighbours and hinges of the paired half-edges; the new hinges take the dropped slots in
// ascending order, then the end. Returns how many hinges were placed.
size_t place_paired_hinges(const Triangles& T, const LocalRefreshScratch& scratch, Topology& topo) {
  const auto& he = scratch.half_edges;
  const std::vector<int32_t>& dropped = scratch.dropped;
  size_t fresh = 0;  // hinges placed so far: they take the dropped slots in ascending order, then the end
  for (const auto& e : he) {
    const auto& e_first = he[e.first];
    if (e_first.count != 2) {  // a boundary edge, or one shared by more than two triangles: unpaired
      topo.neighbor[e.t][e.i] = -1;
      topo.edge_hinge[e.t][e.i] = -1;
      continue;
    }
    if (&e != &e_first) continue;  // the second of a pair: set with the first
    const auto& e1 = he[e.twin];
    topo.neighbor[e.t][e.i] = e1.t;
    topo.neighbor[e1.t][e1.i] = e.t;
    const Tri& q0 = T.tri[e.t];
    const Hinge h{{q0[e.i], q0[(e.i + 1) % 3], q0[(e.i + 2) % 3], T.tri[e1.t][(e1.i + 2) % 3]}};
    int32_t slot;
    if (fresh < dropped.size()) {
      slot = dropped[fresh];
      topo.hinges[slot] = h;
    } else {
      slot = static_cast<int32_t>(topo.hinges.size());
      topo.hinges.push_back(h);
    }
    ++fresh;
    topo.edge_hinge[e.t][e.i] = slot;
    topo.edge_hinge[e1.t][e1.i] = slot;
  }
  return fresh;
}

// Dropped slots left over: filled from the end, highest first (a slot above is already settled). A moved
// hinge's two triangles are found in its first vertex's fan (already up to date).
void fill_left_over_hinge_slots(const std::vector<int32_t>& dropped, size_t fresh, const Triangles& T,
                                Topology& topo) {
  for (size_t k = dropped.size(); k-- > fresh;) {
    const int32_t slot = dropped[k], last = static_cast<int32_t>(topo.hinges.size()) - 1;
    if (slot != last) {
      const Hinge h = topo.hinges[last];
      topo.hinges[slot] = h;
      for (int32_t t : topo.fan(h.v[0]))
        if (const int i = edge_index(T.tri[t], h.v[0], h.v[1]); i >= 0) topo.edge_hinge[t][i] = slot;
    }
    topo.hinges.pop_back();
  }
}

// Boundary links, masses and flags of the affected vertices (in fan order: the same last-wins and
// summation order as the full refresh).
void refresh_affected_boundary(const std::vector<int32_t>& A, int32_t nv, const Material& material,
                               const Triangles& T, LocalRefreshScratch& scratch, Topology& topo, Vertices& V) {
  auto affected = [&](int32_t v) { return is_affected(scratch, v); };
  topo.boundary_next.resize(nv, -1);
  topo.boundary_prev.resize(nv, -1);
  const double areal_density = material.density * material.thickness;
  for (int32_t v : A) {
    int32_t next = -1, prev = -1;
    double mass = 0.0;
    for (int32_t t : topo.fan(v)) {
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
  // The boundary list: the affected vertices and the ids past the new end leave it, the affected ones on the
  // boundary now come back, in one merge (the list is as long as the boundary, not the sheet).
  {
    std::vector<int32_t>& merged = scratch.boundary;
    merged.clear();
    size_t k = 0;
    for (int32_t b : topo.boundary_vertices) {
      if (b >= nv) break;
      for (; k < A.size() && A[k] < b; ++k)
        if (topo.boundary_next[A[k]] >= 0) merged.push_back(A[k]);
      if (!affected(b)) merged.push_back(b);
    }
    for (; k < A.size(); ++k)
      if (topo.boundary_next[A[k]] >= 0) merged.push_back(A[k]);
    topo.boundary_vertices.assign(merged.begin(), merged.end());
  }
  for (int32_t v : A) {
    uint8_t f = V.flags[v] & ~(kBoundary | kInward);
    if (topo.boundary_next[v] >= 0) {
      f |= kBoundary;
      if (interior_pattern_angle(topo, V.rest, v) > std::numbers::pi + 0.05) f |= kInward;
    }
    V.flags[v] = f;
  }
}

// Pieces: a cut that reached the boundary may part the sheet (flood fill again); otherwise the changed
// triangles kept their parent's piece and only the numbering by lowest triangle may need restoring.
void refresh_pieces(bool pieces_may_split, int32_t nt, Topology& topo, std::vector<int32_t>& piece) {
  if (pieces_may_split) {
    topo.piece_count = flood_fill_pieces(topo.neighbor, piece);
  } else if (topo.piece_count > 1) {
    std::vector<int32_t> order(topo.piece_count, -1);  // old piece id → new, by first appearance
    int32_t next_id = 0;
    for (int32_t t = 0; t < nt && next_id < topo.piece_count; ++t)
      if (order[piece[t]] < 0) order[piece[t]] = next_id++;
    bool same = true;
    for (int32_t p = 0; p < topo.piece_count; ++p) same = same && order[p] == p;
    if (!same)
      for (int32_t& p : piece) p = order[p];
  }
}
}  // namespace

void refresh_after_local_change(const LocalTopologyChange& change, Sheet& sheet) {
  Vertices& V = sheet.verts;
  Triangles& T = sheet.tris;
  Topology& topo = sheet.topo;
  const int32_t nv = V.size(), nt = T.size();
  const int32_t nv_before = topo.vertex_count();
  const int32_t nt_before = static_cast<int32_t>(topo.neighbor.size());
  if (topo.version != sheet.topology_version || static_cast<int32_t>(topo.boundary_next.size()) != nv_before ||
      static_cast<int32_t>(topo.edge_hinge.size()) != nt_before) {
    refresh_after_topology_change(sheet);
    return;
  }
  const ChangeSizes sizes{nv, nt, nv_before, nt_before};
  const std::vector<int32_t>& A = change.vertices;  // affected vertices, ascending
  thread_local LocalRefreshScratch scratch;
  stamp_change(change, sizes, scratch);

  T.corner_force.resize(nt, {Vec3::Zero(), Vec3::Zero(), Vec3::Zero()});
  T.region.resize(nt, -1);
  T.side.resize(nt, 0);
  T.rest_inv.resize(nt);
  T.rest_area.resize(nt);
  for (int32_t t : change.triangles) rest_data_of(V.rest, T.tri[t], T.rest_inv[t], T.rest_area[t]);

  collect_dropped_hinges(change, sizes, topo, T, scratch);
  refresh_affected_fans(change, sizes, T, scratch, topo);

  // Neighbours and hinges across the edges at an affected vertex: both triangles of such an edge are around
  // an affected vertex, so pairing the half-edges of those triangles finds them all (an edge pairs exactly two
  // triangles, as in build_topology; more stay unpaired). The other edges, and every triangle away from the
  // change, keep their neighbours and hinges: they are the same triangles under the same ids.
  topo.neighbor.resize(nt, {-1, -1, -1});
  topo.edge_hinge.resize(nt, {-1, -1, -1});
  pair_half_edges_at_affected(A, topo, T, scratch);
  const size_t fresh = place_paired_hinges(T, scratch, topo);
  fill_left_over_hinge_slots(scratch.dropped, fresh, T, topo);

  refresh_affected_boundary(A, nv, sheet.material, T, scratch, topo, V);
  refresh_pieces(change.pieces_may_split, nt, topo, T.piece);

  sheet.topology_version += 1;
  topo.version = sheet.topology_version;
}

double total_rest_area(const Triangles& tris) {
  double a = 0;
  for (double x : tris.rest_area) a += x;
  return a;
}

namespace {
// Each check below returns what is wrong, empty (or null) when nothing is.

std::string array_length_problem(const Vertices& V, const Triangles& T) {
  const int32_t nv = V.size(), nt = T.size();
  if (static_cast<int32_t>(V.v.size()) != nv || static_cast<int32_t>(V.rest.size()) != nv ||
      static_cast<int32_t>(V.mass.size()) != nv || static_cast<int32_t>(V.flags.size()) != nv ||
      static_cast<int32_t>(V.force.size()) != nv || static_cast<int32_t>(V.tear.size()) != nv)
    return "vertex arrays differ in length";
  if (static_cast<int32_t>(T.rest_inv.size()) != nt || static_cast<int32_t>(T.rest_area.size()) != nt ||
      static_cast<int32_t>(T.corner_force.size()) != nt || static_cast<int32_t>(T.piece.size()) != nt)
    return "triangle arrays differ in length";
  return {};
}

// Corners in range, pattern counter-clockwise.
std::string triangle_problem(const Vertices& V, const Triangles& T) {
  const int32_t nv = V.size(), nt = T.size();
  std::ostringstream err;
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
  return {};
}

// Edge manifoldness.
std::string edge_manifold_problem(const Triangles& T, int32_t nv) {
  const int32_t nt = T.size();
  std::ostringstream err;
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
  return {};
}

// Fan connectivity: the triangles around each vertex form one edge-connected fan.
std::string fan_connectivity_problem(const Topology& topo, int32_t nv) {
  std::ostringstream err;
  for (int32_t v = 0; v < nv; ++v) {
    if (topo.fans[v].count == 0) {
      err << "vertex " << v << " belongs to no triangle";
      return err.str();
    }
    std::vector<int32_t> fan(topo.fan(v).begin(), topo.fan(v).end());
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
  return {};
}

std::string total_area_problem(const Vertices& V, const Triangles& T, double expected_area) {
  const int32_t nt = T.size();
  std::ostringstream err;
  double area = 0;
  for (int32_t t = 0; t < nt; ++t) {
    const Vec2 a = V.rest[T.tri[t][0]], b = V.rest[T.tri[t][1]], c = V.rest[T.tri[t][2]];
    area += 0.5 * ((b - a).x() * (c - a).y() - (b - a).y() * (c - a).x());
  }
  if (std::abs(area - expected_area) > 1e-9 * std::max(1.0, expected_area) + 1e-12) {
    err << "total pattern area " << area << " differs from " << expected_area;
    return err.str();
  }
  return {};
}

// The checks below compare the sheet's topology `cur` with `topo`, a full rebuild; each returns what differs.

const char* fan_difference(const Topology& cur, const Topology& topo, int32_t nv) {
  const char* what = nullptr;
  if (cur.vertex_count() != nv) what = "vertex fans";
  for (int32_t v = 0; !what && v < nv; ++v)
    if (!std::ranges::equal(cur.fan(v), topo.fan(v))) what = "vertex fans";
  if (!what) {
    // The pool: every fan inside it and within its room, the rooms disjoint, the rest counted as unused.
    std::vector<std::pair<int32_t, int32_t>> rooms;
    for (const Topology::FanRoom& room : cur.fans) rooms.push_back({room.offset, room.capacity});
    std::sort(rooms.begin(), rooms.end());
    int64_t used = 0, end = 0;
    for (const Topology::FanRoom& room : cur.fans)
      if (room.count > room.capacity) what = "fan rooms";
    for (const auto& [first, capacity] : rooms) {
      if (first < end) what = "fan rooms";
      end = static_cast<int64_t>(first) + capacity;
      used += capacity;
    }
    if (end > static_cast<int64_t>(cur.vt_tri.size()) ||
        used + cur.vt_unused != static_cast<int64_t>(cur.vt_tri.size()))
      what = "fan rooms";
  }
  return what;
}

// The same hinges (with their orientation and opposite vertices), in any order, and each triangle edge
// pointing at the hinge on it.
const char* hinge_difference(const Topology& cur, const Topology& topo, const Triangles& T) {
  const int32_t nt = T.size();
  const char* what = nullptr;
  auto key = [](const Hinge& h) { return std::pair(std::min(h.v[0], h.v[1]), std::max(h.v[0], h.v[1])); };
  std::vector<Hinge> sorted = cur.hinges;
  std::sort(sorted.begin(), sorted.end(), [&](const Hinge& p, const Hinge& q) { return key(p) < key(q); });
  for (size_t h = 0; !what && h < topo.hinges.size(); ++h)
    if (sorted[h].v != topo.hinges[h].v) what = "hinges";
  if (static_cast<int32_t>(cur.edge_hinge.size()) != nt) what = "edge hinges";
  for (int32_t t = 0; !what && t < nt; ++t)
    for (int32_t i = 0; i < 3 && !what; ++i) {
      const int32_t h = cur.edge_hinge[t][i];
      const Tri& q = T.tri[t];
      if (cur.neighbor[t][i] < 0 ? h != -1
                                 : (h < 0 || h >= static_cast<int32_t>(cur.hinges.size()) ||
                                    key(cur.hinges[h]) != std::pair(std::min(q[i], q[(i + 1) % 3]),
                                                                    std::max(q[i], q[(i + 1) % 3]))))
        what = "edge hinges";
    }
  return what;
}

// Rest data, lumped masses and boundary flags as a full refresh would compute them.
const char* rest_data_difference(const Sheet& sheet, const Topology& topo) {
  const Vertices& V = sheet.verts;
  const Triangles& T = sheet.tris;
  const int32_t nv = V.size(), nt = T.size();
  const char* what = nullptr;
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
  return what;
}

// `topo` and `piece`: a full rebuild of the sheet's triangles.
const char* derived_data_difference(const Sheet& sheet, const Topology& topo, const std::vector<int32_t>& piece) {
  const Triangles& T = sheet.tris;
  const Topology& cur = sheet.topo;
  const char* what = fan_difference(cur, topo, sheet.verts.size());
  if (what) {
  } else if (cur.neighbor != topo.neighbor) {
    what = "triangle neighbours";
  } else if (cur.boundary_next != topo.boundary_next || cur.boundary_prev != topo.boundary_prev ||
             cur.boundary_vertices != topo.boundary_vertices) {
    what = "boundary links";
  } else if (cur.piece_count != topo.piece_count || T.piece != piece) {
    what = "pieces";
  } else if (cur.hinges.size() != topo.hinges.size()) {
    what = "hinge count";
  }
  if (!what) what = hinge_difference(cur, topo, T);
  if (!what) what = rest_data_difference(sheet, topo);
  return what;
}
}  // namespace

std::string check_mesh_invariants(const Sheet& sheet, double expected_area) {
  const Vertices& V = sheet.verts;
  const Triangles& T = sheet.tris;
  const int32_t nv = V.size();
  if (std::string e = array_length_problem(V, T); !e.empty()) return e;
  if (std::string e = triangle_problem(V, T); !e.empty()) return e;
  if (std::string e = edge_manifold_problem(T, nv); !e.empty()) return e;
  Topology topo;
  std::vector<int32_t> piece;
  build_topology(T.tri, nv, topo, piece);
  if (std::string e = fan_connectivity_problem(topo, nv); !e.empty()) return e;
  if (expected_area >= 0)
    if (std::string e = total_area_problem(V, T, expected_area); !e.empty()) return e;
  // Derived data kept up to date by the local refresh after a cut must equal a full rebuild, bit for bit.
  if (sheet.topo.version == sheet.topology_version)
    if (const char* what = derived_data_difference(sheet, topo, piece))
      return std::string("the topology's ") + what + " differ from a full rebuild";
  return {};
}

std::string first_non_finite(const Sheet& s) {
  for (int32_t v = 0; v < s.verts.size(); ++v)
    if (!s.verts.x[v].allFinite() || !s.verts.v[v].allFinite() || !s.verts.rest[v].allFinite())
      return "vertex " + std::to_string(v);
  for (const Finger& f : s.fingers)
    if (!f.target.allFinite() || !f.reaction.allFinite()) return "finger " + f.name;
  for (const Tear& t : s.tears) {
    for (const Vec2& p : t.tips)
      if (!p.allFinite()) return "tear tip";
    for (const Vec2& p : t.detail)
      if (!p.allFinite()) return "tear detail";
  }
  return "";
}

}  // namespace pt
