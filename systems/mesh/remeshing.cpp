// Cutting a tear segment into the coarse mesh (paper §5.3, appendix A; docs/tearing.md "The cut").
//
// Everything happens in the 2D pattern (verts.rest). The cut runs in four phases:
//   1. walk: from boundary vertex p, follow the segment p → next triangle by triangle, splitting each
//      crossed edge as it is met (or snapping the crossing onto a nearby vertex), until `next` lies in the
//      current triangle (inserted there, or snapped onto a vertex or an edge) or the boundary is hit.
//      After the walk the path is a chain of mesh edges v0 = p, v1, ..., vk.
//   2. cut: every path vertex except the final tip is duplicated; the copy takes the triangles on the
//      right of the path, so the two lips no longer share edges (appendix A: the tear becomes boundary).
//   3. split or remove p (Fig. 8): a straight continuation removes p from both lips by collapsing it along
//      its lip's boundary, so a straight tear does not leave a vertex per step (keep the mesh coarse).
//   4. compaction of the dense arrays (swap-with-last), remapping of finger and tip ids, refresh.
// The walk only touches the triangles the segment crosses; the vertex fans it needs come from the topology
// of the sheet at entry plus the short list of triangles this cut has modified or appended.
#include "systems/mesh/remeshing.hpp"

#include "systems/common/topology.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>

namespace pt {
namespace {

// An edge is never split closer to one of its ends than this fraction of its length (a sliver whose
// stiffness the implicit solve cannot factor).
constexpr double kEdgeEnd = 0.01;
// A point this close to a vertex or an edge of its triangle (a fraction of the triangle's mean edge) is on
// it whatever the snap fraction: inserting it into the triangle would leave a triangle of (nearly) zero
// area. Snap fraction 0 otherwise cut a zero-area triangle (issue 27, item 12).
constexpr double kOnFeature = 1e-6;

double cross2(const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); }

// A short list of vertex or triangle ids kept inline (fans and neighbourhoods of a cut hold a handful):
// the walk asks for fans dozens of times per cut, each a heap allocation as a std::vector (13% of a cut
// at ~100 triangles, BM_RemeshOneCut 8.9 -> 7.7 us). Spills to the heap past kInline ids (a hub vertex),
// same order either way.
class IdList {
 public:
  static constexpr int32_t kInline = 32;
  int32_t* begin() { return spilled() ? heap_.data() : inline_.data(); }
  int32_t* end() { return begin() + n_; }
  const int32_t* begin() const { return spilled() ? heap_.data() : inline_.data(); }
  const int32_t* end() const { return begin() + n_; }
  size_t size() const { return static_cast<size_t>(n_); }
  bool empty() const { return n_ == 0; }
  int32_t operator[](size_t i) const { return begin()[i]; }
  void push_back(int32_t v) {
    if (!spilled()) {
      if (n_ < kInline) {
        inline_[n_++] = v;
        return;
      }
      heap_.assign(inline_.begin(), inline_.end());
    }
    heap_.push_back(v);
    ++n_;
  }
  // Keeps the ids before new_end (a position in this list).
  void truncate(const int32_t* new_end) {
    n_ = static_cast<int32_t>(new_end - begin());
    if (spilled()) heap_.resize(n_);
  }
  void sort_unique() {
    std::sort(begin(), end());
    truncate(std::unique(begin(), end()));
  }

 private:
  bool spilled() const { return !heap_.empty(); }
  std::array<int32_t, kInline> inline_{};
  std::vector<int32_t> heap_;
  int32_t n_ = 0;
};

bool contains(const Tri& t, int32_t v) { return t[0] == v || t[1] == v || t[2] == v; }

int corner_of(const Tri& t, int32_t v) {
  for (int i = 0; i < 3; ++i)
    if (t[i] == v) return i;
  return -1;
}

// Triangle rotated so that v is its first corner (counter-clockwise order kept).
Tri rotated_to(const Tri& t, int32_t v) {
  const int i = corner_of(t, v);
  return Tri{t[i], t[(i + 1) % 3], t[(i + 2) % 3]};
}

double min_angle(const Vec2& a, const Vec2& b, const Vec2& c) {
  auto ang = [](const Vec2& p, const Vec2& q, const Vec2& r) {
    const Vec2 u = q - p, w = r - p;
    return std::atan2(std::abs(cross2(u, w)), u.dot(w));
  };
  return std::min({ang(a, b, c), ang(b, c, a), ang(c, a, b)});
}

// Working state of one cut. `undo` keeps the original corners of every pre-existing triangle the cut
// modified, so a cut that gives up restores the sheet bit for bit (appended items are simply truncated).
struct Cut {
  Sheet& S;
  const Topology& topo;  // topology of the sheet at entry (valid for ids < n0 / nt0)
  int32_t n0, nt0;
  std::vector<int32_t> touched;  // triangles modified or appended by this cut, ascending, unique
  std::vector<std::pair<int32_t, Tri>> undo;
  int32_t created = 0;

  Cut(Sheet& s, const Topology& t) : S(s), topo(t), n0(s.verts.size()), nt0(s.tris.size()) {}

  const Vec2& r(int32_t v) const { return S.verts.rest[v]; }
  const Tri& tri(int32_t t) const { return S.tris.tri[t]; }

  void touch(int32_t t) {
    auto it = std::lower_bound(touched.begin(), touched.end(), t);
    if (it == touched.end() || *it != t) touched.insert(it, t);
  }

  // Triangles around v now, ascending ids (deterministic).
  IdList fan(int32_t v) const {
    IdList f;
    if (v < n0)
      for (int32_t t : topo.fan(v))
        if (contains(tri(t), v)) f.push_back(t);
    for (int32_t t : touched)
      if (contains(tri(t), v)) f.push_back(t);
    f.sort_unique();
    return f;
  }

  IdList edge_tris(int32_t a, int32_t b) const {
    IdList e;
    for (int32_t t : fan(a))
      if (contains(tri(t), b)) e.push_back(t);
    return e;
  }

  bool boundary_edge(int32_t a, int32_t b) const { return edge_tris(a, b).size() == 1; }

  // A vertex is on the boundary when one of its fan's edges has a single triangle.
  bool boundary_vertex(int32_t v) const {
    IdList nb;
    for (int32_t t : fan(v)) {
      const Tri q = rotated_to(tri(t), v);
      nb.push_back(q[1]);
      nb.push_back(q[2]);
    }
    std::sort(nb.begin(), nb.end());
    for (size_t i = 0; i < nb.size();) {
      size_t j = i;
      while (j < nb.size() && nb[j] == nb[i]) ++j;
      if (j - i == 1) return true;
      i = j;
    }
    return false;
  }

  IdList neighbours(int32_t v) const {
    IdList nb;
    for (int32_t t : fan(v))
      for (int32_t c : tri(t))
        if (c != v) nb.push_back(c);
    nb.sort_unique();
    return nb;
  }

  void set_tri(int32_t t, const Tri& q) {
    if (t < nt0 && std::none_of(undo.begin(), undo.end(), [t](const auto& u) { return u.first == t; }))
      undo.push_back({t, tri(t)});
    S.tris.tri[t] = q;
    touch(t);
  }

  // Appended triangles inherit the region and texture side of the triangle they were split from.
  void add_tri(const Tri& q, int32_t parent) {
    Triangles& T = S.tris;
    T.tri.push_back(q);
    T.rest_inv.push_back(Mat2::Identity());
    T.rest_area.push_back(0.0);
    T.corner_force.push_back({Vec3::Zero(), Vec3::Zero(), Vec3::Zero()});
    T.region.push_back(T.region[parent]);
    T.piece.push_back(T.piece[parent]);
    T.side.push_back(T.side[parent]);
    touch(T.size() - 1);
  }

  // New vertices start at rest (zero velocity, paper §5.3) and carry kNew.
  int32_t add_vertex(const Vec2& rest, const Vec3& x, int32_t tear) {
    Vertices& V = S.verts;
    V.x.push_back(x);
    V.v.push_back(Vec3::Zero());
    V.force.push_back(Vec3::Zero());
    V.rest.push_back(rest);
    V.mass.push_back(0.0);
    V.flags.push_back(kNew);
    V.tear.push_back(tear);
    ++created;
    return V.size() - 1;
  }

  void rollback() {
    for (auto it = undo.rbegin(); it != undo.rend(); ++it) S.tris.tri[it->first] = it->second;
    S.tris.tri.resize(nt0);
    S.tris.rest_inv.resize(nt0);
    S.tris.rest_area.resize(nt0);
    S.tris.corner_force.resize(nt0);
    S.tris.region.resize(nt0);
    S.tris.piece.resize(nt0);
    S.tris.side.resize(nt0);
    Vertices& V = S.verts;
    V.x.resize(n0);
    V.v.resize(n0);
    V.force.resize(n0);
    V.rest.resize(n0);
    V.mass.resize(n0);
    V.flags.resize(n0);
    V.tear.resize(n0);
  }

  // Splits edge (a, b) at parameter s from a: both adjacent triangles are split in two (the new vertex is
  // joined to each opposite corner), so the path through the new vertex lies on mesh edges.
  int32_t split_edge(int32_t a, int32_t b, double s, int32_t tear) {
    const Vec2 p = r(a) + s * (r(b) - r(a));
    const Vec3 x = S.verts.x[a] + s * (S.verts.x[b] - S.verts.x[a]);
    const int32_t w = add_vertex(p, x, tear);
    for (int32_t t : edge_tris(a, b)) {
      const Tri q = tri(t);
      int i = 0;
      while (!((q[i] == a && q[(i + 1) % 3] == b) || (q[i] == b && q[(i + 1) % 3] == a))) ++i;
      const int32_t u = q[i], v = q[(i + 1) % 3], c = q[(i + 2) % 3];
      set_tri(t, Tri{u, w, c});
      add_tri(Tri{w, v, c}, t);
    }
    return w;
  }

  // 1 → 3 split of triangle t at pattern point p (3D position by barycentric interpolation).
  int32_t insert_in_triangle(int32_t t, const Vec2& p, int32_t tear) {
    const Tri q = tri(t);
    const Vec2 &A = r(q[0]), &B = r(q[1]), &C = r(q[2]);
    const double area = cross2(B - A, C - A);
    const double la = cross2(B - p, C - p) / area, lb = cross2(C - p, A - p) / area;
    const double lc = 1.0 - la - lb;
    const Vec3 x = la * S.verts.x[q[0]] + lb * S.verts.x[q[1]] + lc * S.verts.x[q[2]];
    const int32_t e = add_vertex(p, x, tear);
    set_tri(t, Tri{q[0], q[1], e});
    add_tri(Tri{q[1], q[2], e}, t);
    add_tri(Tri{q[2], q[0], e}, t);
    return e;
  }
};

// Triangle of cur's fan whose angular sector at cur contains direction d (unit), −1 if none.
// `exclude` (≥ 0) drops triangles holding that vertex: after crossing an edge the walk must not turn back
// into the triangles it came from, whatever the rounding. At a boundary start vertex the direction must
// point strictly inside the open fan (along a boundary edge is "out of the sheet").
int32_t sector_triangle(const Cut& C, int32_t cur, const Vec2& d, int32_t exclude, bool strict) {
  int32_t best = -1;
  double best_violation = 0;
  for (int32_t t : C.fan(cur)) {
    if (exclude >= 0 && contains(C.tri(t), exclude)) continue;
    const Tri q = rotated_to(C.tri(t), cur);
    const Vec2 ea = (C.r(q[1]) - C.r(cur)).normalized(), eb = (C.r(q[2]) - C.r(cur)).normalized();
    if (d.dot(ea + eb) <= 0) continue;  // the opposite direction of a thin sector
    const double ca = cross2(ea, d), cb = cross2(d, eb);
    if (strict) {
      // Boundary edges at the start vertex bound the sheet: d must leave them by a real angle.
      if (C.boundary_edge(cur, q[1]) && ca <= 1e-9) continue;
      if (C.boundary_edge(cur, q[2]) && cb <= 1e-9) continue;
    }
    const double violation = std::max({0.0, -ca, -cb});
    if (strict && violation > 0) continue;
    if (best < 0 || violation < best_violation) {  // ascending ids: the first wins ties (determinism)
      best_violation = violation;
      best = t;
      if (violation == 0) break;
    }
  }
  if (best >= 0 && best_violation > (strict ? 0.0 : 1e-7)) return -1;
  return best;
}

// Vertices on the right of the path at path vertex i (right = clockwise from the outgoing path edge to the
// incoming one). Open fans (start vertex, boundary end vertex) run from the path edge to the boundary.
// Returns false if the fan does not have the expected shape.
bool right_side(const Cut& C, const std::vector<int32_t>& path, size_t i, std::vector<int32_t>& out) {
  const int32_t v = path[i];
  const IdList fan = C.fan(v);
  auto find = [&](auto pred) {
    for (int32_t t : fan) {
      const Tri q = rotated_to(C.tri(t), v);
      if (pred(q)) return t;
    }
    return int32_t{-1};
  };
  out.clear();
  const size_t guard = fan.size() + 1;
  if (i + 1 < path.size()) {
    // Clockwise from the triangle (v, x, next) until the triangle (v, prev, y), or the boundary for p.
    const int32_t next = path[i + 1];
    const int32_t prev = i > 0 ? path[i - 1] : -1;
    int32_t t = find([&](const Tri& q) { return q[2] == next; });
    while (t >= 0 && out.size() < guard) {
      out.push_back(t);
      const Tri q = rotated_to(C.tri(t), v);
      if (q[1] == prev) return true;
      const int32_t x = q[1];
      t = find([&](const Tri& q2) { return q2[2] == x; });
    }
    return prev < 0 && !out.empty() && out.size() < guard;
  }
  // Last vertex on the boundary: counter-clockwise from the triangle (v, prev, y) to the boundary.
  const int32_t prev = path[i - 1];
  int32_t t = find([&](const Tri& q) { return q[1] == prev; });
  while (t >= 0 && out.size() < guard) {
    out.push_back(t);
    const int32_t y = rotated_to(C.tri(t), v)[2];
    t = find([&](const Tri& q2) { return q2[1] == y; });
  }
  return !out.empty() && out.size() < guard;
}

// Boundary neighbours of a boundary vertex from its (open) fan: next follows v along the boundary with the
// interior on the left (edge v→next in a triangle without a twin), prev precedes it.
std::pair<int32_t, int32_t> boundary_neighbours(const Cut& C, int32_t v) {
  IdList after, before;
  for (int32_t t : C.fan(v)) {
    const Tri q = rotated_to(C.tri(t), v);
    after.push_back(q[1]);
    before.push_back(q[2]);
  }
  int32_t next = -1, prev = -1;
  for (int32_t a : after)
    if (std::find(before.begin(), before.end(), a) == before.end()) next = a;
  for (int32_t b : before)
    if (std::find(after.begin(), after.end(), b) == after.end()) prev = b;
  return {next, prev};
}

// Edge collapse of boundary vertex v into its boundary neighbour q (Fig. 8 right). Valid when the link
// condition holds (no edge gets three triangles, no bow-tie) and every remaining triangle stays
// counter-clockwise; `quality` is the smallest angle of the changed triangles.
bool collapse_ok(const Cut& C, int32_t v, int32_t q, double& quality) {
  const IdList fan = C.fan(v);
  int32_t removed = -1, apex = -1;
  quality = std::numbers::pi;
  for (int32_t t : fan) {
    Tri k = C.tri(t);
    if (contains(k, q)) {
      if (removed >= 0) return false;  // q–v is not a boundary edge
      removed = t;
      for (int32_t c : k)
        if (c != v && c != q) apex = c;
      continue;
    }
    k[corner_of(k, v)] = q;
    const Vec2 &a = C.r(k[0]), &b = C.r(k[1]), &c = C.r(k[2]);
    const double scale = std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()});
    if (!(cross2(b - a, c - a) > 1e-12 * scale)) return false;
    quality = std::min(quality, min_angle(a, b, c));
  }
  if (removed < 0) return false;
  // The vanishing triangle must not be the last one of its apex, or of q when v has no other to hand over
  // (a vertex left without triangles).
  // It may be v's only one: a sliver (a, v, b) along a straight tear simply disappears, the other lip's
  // re-based triangles cover its area.
  if (C.fan(apex).size() < 2 || (C.fan(q).size() < 2 && fan.size() < 2)) return false;
  const IdList nv = C.neighbours(v), nq = C.neighbours(q);
  std::array<int32_t, 2> common{};
  int32_t shared = 0;
  for (const int32_t* a = nv.begin(), *b = nq.begin(); a != nv.end() && b != nq.end() && shared < 2;) {
    if (*a < *b) ++a;
    else if (*b < *a) ++b;
    else common[shared++] = *a++, ++b;
  }
  return shared == 1 && common[0] == apex;
}

void apply_collapse(Cut& C, int32_t v, int32_t q) {
  for (int32_t t : C.fan(v)) {
    Tri k = C.tri(t);
    if (contains(k, q)) {
      C.set_tri(t, Tri{-1, -1, -1});  // dead, compacted at the end
    } else {
      k[corner_of(k, v)] = q;
      C.set_tri(t, k);
    }
  }
}

// The segment a cut walks: from boundary vertex p towards the pattern point next; the vertices it creates
// belong to tear tear_id.
struct Segment {
  int32_t p;
  Vec2 next;
  int32_t tear_id;
  const RemeshParams& params;
};

// What the walk leaves behind: the chain of mesh edges path[0] = p, ..., path.back().
struct WalkedPath {
  std::vector<int32_t> path;
  bool reached_boundary = false;
};

// The triangle t = (cur, a, b) of cur's fan that the segment runs into, with the lengths the walk snaps by.
struct WalkTriangle {
  int32_t cur, t, a, b;
  Vec2 pc, A, B;
  double dn;        // distance from cur to next
  double h;         // mean edge of the triangle
  double r_vertex;  // snap radius to a vertex
  double r_edge;    // "very close" to an edge
  double ab_len;
  double inside;    // distance of next from ab, > 0 on cur's side
};

// A vertex may be snapped to unless it is already on the path, or reaching it would run along the
// boundary (an edge of the start vertex's open fan).
bool snappable_vertex(const Cut& C, const std::vector<int32_t>& path, int32_t cur, int32_t u) {
  return std::find(path.begin(), path.end(), u) == path.end() && !C.boundary_edge(cur, u);
}

// Where the tear reaches the boundary it ends, so the point where it does need not be exact: an offset
// there does not carry on along the hyperbola (docs/tearing.md "How far"). A split of edge uw at parameter
// s that would leave a triangle with an angle below min_angle_deg at the walk's vertex `cur` goes to the
// nearer end of the edge instead when that end is on the boundary (the tear then ends there) and may be
// snapped to (snappable_vertex); returns that end, or −1 to split. Elsewhere crossings keep
// snap_fraction. Measured: table-tear on 1 100 triangles crossed an edge 0.15 mm from a boundary vertex
// on its way there and left a sliver (angles of 1.8°) strained to 56%.
int32_t boundary_split_end(const Cut& C, const std::vector<int32_t>& path, int32_t cur, int32_t u, int32_t w, double s,
                           const RemeshParams& params) {
  const int32_t end = s < 0.5 ? u : w;
  if (u == cur || w == cur || !C.boundary_vertex(end)) return -1;
  const Vec2 pc = C.r(cur), U = C.r(u), W = C.r(w);
  const Vec2 X = U + s * (W - U);
  const double thinnest = std::min(min_angle(pc, U, X), min_angle(pc, X, W));
  if (!(thinnest < params.min_angle_deg * std::numbers::pi / 180.0)) return -1;
  return snappable_vertex(C, path, cur, end) ? end : -1;
}

// Last step of the walk, `next` in triangle wt.t: snap it to a vertex, onto an edge, or insert it (1 → 3).
void end_walk_in_triangle(const Segment& seg, const WalkTriangle& wt, Cut& C, WalkedPath& walked) {
  const int32_t cur = wt.cur, p = seg.p, t = wt.t, a = wt.a, b = wt.b;
  const Vec2 &pc = wt.pc, &A = wt.A, &B = wt.B, &next = seg.next;
  const double dn = wt.dn, h = wt.h, r_vertex = wt.r_vertex, r_edge = wt.r_edge, ab_len = wt.ab_len;
  const double inside = wt.inside;
  const RemeshParams& params = seg.params;
  const int32_t tear_id = seg.tear_id;
  std::vector<int32_t>& path = walked.path;
  bool& reached_boundary = walked.reached_boundary;
  auto snappable = [&](int32_t u) { return snappable_vertex(C, path, cur, u); };

  // The snap radius of a corner is a fraction of its shorter edge in this triangle: the slivers a
  // nearby point would create are thin relative to those edges.
  const double l_ca = (A - pc).norm(), l_cb = (B - pc).norm();
  int32_t snap_v = -1;
  double best = std::numeric_limits<double>::infinity();
  for (int32_t u : {a, b}) {
    const double radius = std::max(params.snap_fraction * std::min(ab_len, u == a ? l_ca : l_cb), kOnFeature * h);
    const double dist = (C.r(u) - next).norm();
    if (snappable(u) && dist < radius && dist < best) {
      best = dist;
      snap_v = u;
    }
  }
  if (snap_v >= 0) {
    path.push_back(snap_v);
    reached_boundary = C.boundary_vertex(snap_v);
    return;
  }
  // The walk already stands on a vertex close to next.
  if (cur != p && dn < std::max(params.snap_fraction * std::min(l_ca, l_cb), kOnFeature * h)) return;
  // Nearest edge of the triangle whose interior faces next (edges of the start vertex's open fan
  // excluded: the tear cannot run along the boundary).
  const std::array<std::pair<int32_t, int32_t>, 3> edges{{{cur, a}, {a, b}, {b, cur}}};
  int32_t best_edge = -1;
  double best_dist = 0, best_s = 0;
  for (int32_t k = 0; k < 3; ++k) {
    const auto [u, w] = edges[k];
    if ((u == cur || w == cur) && C.boundary_edge(u, w)) continue;
    const Vec2 U = C.r(u), W = C.r(w);
    const double s = (next - U).dot(W - U) / (W - U).squaredNorm();
    if (!(s > 0 && s < 1)) continue;  // nearest to a corner, not to the edge
    const double dist = (U + s * (W - U) - next).norm();
    if (best_edge < 0 || dist < best_dist) {
      best_edge = k;
      best_dist = dist;
      best_s = s;
    }
  }
  // Snap onto the edge when very close (a 1 → 3 insertion would be a sliver, or flat when next is on
  // the edge), or when the insertion would make an angle below min_angle_deg and a snap well inside
  // the edge avoids it.
  bool on_edge = best_edge >= 0 && best_dist < r_edge;
  if (!on_edge && best_edge >= 0 && best_dist < 0.5 * r_vertex && best_s > 0.1 && best_s < 0.9) {
    const double worst = std::min({min_angle(pc, A, next), min_angle(A, B, next), min_angle(B, pc, next)});
    on_edge = worst < params.min_angle_deg * std::numbers::pi / 180.0;
  }
  if (!(inside > 0) && !on_edge) {
    // next is outside the triangle within r_edge: it can only go onto edge ab.
    on_edge = true;
    best_edge = 1;
    best_s = std::clamp((next - A).dot(B - A) / (B - A).squaredNorm(), 0.0, 1.0);
  }
  if (on_edge) {
    const auto [u, w] = edges[best_edge];
    // A point at an end of the edge is that vertex: splitting the edge there would leave a sliver
    // (measured: a vertex 2·10⁻⁸ m from another, pivots of condition 10¹⁷ in the implicit solve). Go to
    // the vertex, or end the cut where it stands when the vertex may not be snapped to.
    int32_t end_vertex = best_s < kEdgeEnd ? u : 1 - best_s < kEdgeEnd ? w : -1;
    if (end_vertex < 0) end_vertex = boundary_split_end(C, path, cur, u, w, best_s, params);
    if (end_vertex >= 0) {
      if (end_vertex != cur && snappable(end_vertex)) {
        path.push_back(end_vertex);
        reached_boundary = C.boundary_vertex(end_vertex);
      }
      return;
    }
    const bool boundary = C.boundary_edge(u, w);
    path.push_back(C.split_edge(u, w, best_s, tear_id));  // best_s in [kEdgeEnd, 1 − kEdgeEnd]
    reached_boundary = boundary;
  } else {
    path.push_back(C.insert_in_triangle(t, next, tear_id));
  }
}

// ---- 1–2. Walk and split (paper §5.3: "p_next has to be integrated into the boundary"). ----
// A path of fewer than two vertices means the segment could not be walked.
WalkedPath walk_and_split(const Segment& seg, Cut& C) {
  const int32_t p = seg.p;
  const Vec2& next = seg.next;
  const RemeshParams& params = seg.params;
  const int32_t tear_id = seg.tear_id;
  WalkedPath walked;
  std::vector<int32_t>& path = walked.path;
  bool& reached_boundary = walked.reached_boundary;
  path.push_back(p);
  bool from_crossing = false;  // cur was created on a crossed edge (do not turn back into its old side)
  int32_t cur = p;
  const int32_t max_steps = 4 * (C.S.tris.size() + 4);
  for (int32_t step = 0; step < max_steps; ++step) {
    const Vec2 pc = C.r(cur);
    const Vec2 d = next - pc;
    const double dn = d.norm();
    if (cur != p && dn == 0) break;
    const int32_t exclude = from_crossing && path.size() >= 2 ? path[path.size() - 2] : -1;
    const int32_t t = dn > 0 ? sector_triangle(C, cur, d / dn, exclude, cur == p) : -1;
    if (t < 0) break;  // at p: d points out of the sheet (nothing modified yet)
    const Tri q = rotated_to(C.tri(t), cur);
    const int32_t a = q[1], b = q[2];
    const Vec2 A = C.r(a), B = C.r(b);
    const double h = ((A - pc).norm() + (B - pc).norm() + (B - A).norm()) / 3.0;
    const double r_vertex = params.snap_fraction * h;  // snap radius to a vertex
    const double r_edge = std::max(0.2 * r_vertex, kOnFeature * h);  // "very close" to an edge
    if (cur == p && dn < 1e-6 * h) break;              // degenerate segment

    auto snappable = [&](int32_t u) { return snappable_vertex(C, path, cur, u); };

    const double ab_len = (B - A).norm();
    const double inside = cross2(B - A, next - A) / ab_len;  // distance of next from ab, > 0 on cur's side
    if (inside >= -r_edge) {
      end_walk_in_triangle(seg, WalkTriangle{cur, t, a, b, pc, A, B, dn, h, r_vertex, r_edge, ab_len, inside},
                           C, walked);
      break;
    }

    // The segment leaves through edge ab at parameter s (from a): split it there, or snap to a or b when
    // the crossing is within snap_fraction of them (no slivers).
    const Vec2 D = d;
    const double denom = cross2(D, B - A);
    double s = denom != 0 ? cross2(A - pc, D) / denom : 0.5;
    s = std::clamp(s, 0.0, 1.0);
    int32_t u = -1;
    if (s < params.snap_fraction && snappable(a)) u = a;
    else if (s > 1.0 - params.snap_fraction && snappable(b)) u = b;
    else u = boundary_split_end(C, path, cur, a, b, s, params);
    // A snap must bring the walk closer to next (so the walk always ends; without the snap the tear may stop
    // at cur, below, rather than turn back).
    if (u >= 0 && !((next - C.r(u)).norm() < dn)) u = -1;
    const Vec2 point = u >= 0 ? C.r(u) : Vec2(A + s * (B - A));
    if (!((next - point).norm() < dn)) break;  // no progress (rounding): stop the tear at cur
    // A crossing at an end of the edge that may not be snapped to would split the edge into a sliver: the
    // tear stops at cur instead.
    if (u < 0 && std::min(s, 1 - s) < kEdgeEnd) break;
    if (u >= 0) {
      path.push_back(u);
      from_crossing = false;
      if (C.boundary_vertex(u)) {
        reached_boundary = true;
        break;
      }
    } else {
      const bool boundary = C.boundary_edge(a, b);
      path.push_back(C.split_edge(a, b, s, tear_id));  // s in [kEdgeEnd, 1 − kEdgeEnd]
      from_crossing = true;
      if (boundary) {
        reached_boundary = true;
        break;
      }
    }
    cur = path.back();
  }
  return walked;
}

// ---- 3. Cut: duplicate the path vertices, the copy takes the right-hand triangles. ----
// copy[i] is the copy of path[i]. Returns false, the sheet untouched, when a fan does not have the expected
// shape.
bool cut_along_path(const Segment& seg, const WalkedPath& walked, Cut& C, std::vector<int32_t>& copy) {
  const std::vector<int32_t>& path = walked.path;
  const bool reached_boundary = walked.reached_boundary;
  const int32_t p = seg.p, tear_id = seg.tear_id;
  Sheet& sheet = C.S;
  const size_t k = path.size() - 1;
  const size_t dup_count = reached_boundary ? k + 1 : k;
  std::vector<std::vector<int32_t>> right(dup_count);
  for (size_t i = 0; i < dup_count; ++i)
    if (!right_side(C, path, i, right[i])) return false;
  // kNew marks the vertices of the last remesh only.
  for (int32_t v = 0; v < C.n0; ++v) sheet.verts.flags[v] &= static_cast<uint8_t>(~kNew);
  copy.assign(dup_count, 0);
  for (size_t i = 0; i < dup_count; ++i) {
    const int32_t v = path[i];
    copy[i] = C.add_vertex(sheet.verts.rest[v], sheet.verts.x[v], tear_id);
    for (int32_t t : right[i]) {
      Tri q = C.tri(t);
      q[corner_of(q, v)] = copy[i];
      C.set_tri(t, q);
    }
  }
  for (int32_t v : path) sheet.verts.tear[v] = tear_id;
  // The tear's tip moves on: p is no longer a tip, the new tip is.
  sheet.verts.flags[p] &= static_cast<uint8_t>(~kTip);
  sheet.verts.flags[copy[0]] &= static_cast<uint8_t>(~kTip);
  if (!reached_boundary) sheet.verts.flags[path.back()] |= kTip;
  return true;
}

// The start vertex p of a cut and what decides whether it stays a corner of both lips.
struct CutStart {
  int32_t p;
  int32_t p_copy;           // its copy on the right-hand lip
  Vec2 previous_direction;  // of the tear before this segment (zero: always keep p)
  Vec2 d0;                  // of this segment
};

// ---- 4. Split or remove p (Fig. 8). ----
// Returns the removed vertices, each with the vertex it merged into.
std::vector<std::pair<int32_t, int32_t>> remove_straight_start(const CutStart& start, const RemeshParams& params,
                                                               Cut& C) {
  const int32_t p = start.p;
  const Vec2 &previous_direction = start.previous_direction, &d0 = start.d0;
  std::vector<std::pair<int32_t, int32_t>> removed;  // (vertex, vertex it merged into)
  const double turn = std::atan2(std::abs(cross2(previous_direction, d0)), previous_direction.dot(d0));
  bool held = false;
  for (const Finger& f : C.S.fingers)
    held = held || f.vertex == p || std::find(f.pad.begin(), f.pad.end(), p) != f.pad.end();
  if (previous_direction.squaredNorm() > 0 && d0.squaredNorm() > 0 && turn <= params.split_angle && !held) {
    // Removing p from both lips keeps the area only when both lips come back along the same line, i.e. the
    // back neighbours are the two copies of the previous tear vertex: each lip's boundary a–p–b becomes the
    // straight a–b, one lip gains the wedge (a, p, b) that the other loses.
    const auto [next_l, prev_l] = boundary_neighbours(C, p);
    const auto [next_r, prev_r] = boundary_neighbours(C, start.p_copy);
    const bool mirrored = prev_l >= 0 && next_r >= 0 && prev_l != next_r && next_l >= 0 && prev_r >= 0 &&
                          C.r(prev_l) == C.r(next_r) && C.r(next_l) == C.r(prev_r);
    if (mirrored) {
      auto choose = [&](int32_t v, int32_t n1, int32_t n2) {
        int32_t best = -1;
        double best_q = -1, q = 0;
        for (int32_t n : {n1, n2})
          if (collapse_ok(C, v, n, q) && q > best_q) {
            best_q = q;
            best = n;
          }
        return best;
      };
      const int32_t into_l = choose(p, prev_l, next_l);
      const int32_t into_r = choose(start.p_copy, next_r, prev_r);
      if (into_l >= 0 && into_r >= 0) {
        apply_collapse(C, p, into_l);
        apply_collapse(C, start.p_copy, into_r);
        removed.push_back({start.p_copy, into_r});
        removed.push_back({p, into_l});
      }
    }
  }
  return removed;
}

// ---- 5. Compaction: dead triangles and removed vertices go by swap-with-last. ----
// Only the triangles this cut touched, moved or renamed are visited, and they are handed to the local
// topology refresh with every vertex whose fan they change.

struct TriangleCompaction {
  std::vector<int32_t> dead;                       // descending ids
  std::vector<std::pair<int32_t, int32_t>> moves;  // (id before the cut, slot now) of moved survivors
};

TriangleCompaction compact_dead_triangles(const Cut& C, Triangles& T) {
  TriangleCompaction tc;
  std::vector<int32_t>& dead = tc.dead;
  std::vector<std::pair<int32_t, int32_t>>& tri_moves = tc.moves;
  for (int32_t t : C.touched)
    if (T.tri[t][0] < 0) dead.push_back(t);
  std::sort(dead.rbegin(), dead.rend());
  for (int32_t t : dead) {
    const int32_t last = T.size() - 1;
    if (t != last) {
      T.copy_entry(last, t);
      auto it = std::find_if(tri_moves.begin(), tri_moves.end(), [&](const auto& m) { return m.second == last; });
      if (it != tri_moves.end()) it->second = t;  // moved twice: keep its origin
      else tri_moves.push_back({last, t});
    }
    T.resize(last);
  }
  return tc;
}

// A triangle id from before the compaction (touched, or from the entry topology) → its slot now, −1 if dead.
int32_t triangle_now(const TriangleCompaction& tc, const Triangles& T, int32_t t) {
  for (const auto& m : tc.moves)
    if (m.first == t) return m.second;
  if (std::binary_search(tc.dead.rbegin(), tc.dead.rend(), t)) return -1;
  return t < T.size() ? t : -1;
}

struct VertexCompaction {
  std::vector<std::pair<int32_t, int32_t>> removed;  // (vertex, vertex it merged into)
  int32_t count_before = 0;                          // vertices before the compaction
  std::vector<int32_t> gone;                         // removed vertices, descending
  std::vector<std::pair<int32_t, int32_t>> moves;    // (id before, slot now) of moved vertices
};

VertexCompaction compact_removed_vertices(const std::vector<std::pair<int32_t, int32_t>>& removed, Vertices& V) {
  VertexCompaction vc;
  vc.removed = removed;
  vc.count_before = V.size();
  std::vector<std::pair<int32_t, int32_t>>& vertex_moves = vc.moves;
  std::vector<int32_t>& gone = vc.gone;
  for (const auto& rm : removed) gone.push_back(rm.first);
  std::sort(gone.rbegin(), gone.rend());
  for (int32_t v : gone) {
    const int32_t last = V.size() - 1;
    if (v != last) {
      V.copy_entry(last, v);
      auto it = std::find_if(vertex_moves.begin(), vertex_moves.end(), [&](const auto& m) { return m.second == last; });
      if (it != vertex_moves.end()) it->second = v;
      else vertex_moves.push_back({last, v});
    }
    V.resize(last);
  }
  return vc;
}

// Vertex id before the compaction → id now, −1 for a removed vertex.
int32_t vertex_now(const VertexCompaction& vc, int32_t v) {
  for (const auto& m : vc.moves)
    if (m.first == v) return m.second;
  if (std::find(vc.gone.begin(), vc.gone.end(), v) != vc.gone.end()) return -1;
  return v;
}

// Like vertex_now, but a removed vertex lives on in the one it merged into; ids that were no vertex stay.
int32_t remapped_vertex(const VertexCompaction& vc, int32_t v) {
  if (v < 0 || v >= vc.count_before) return v;
  for (const auto& rm : vc.removed)
    if (rm.first == v) v = rm.second;  // a removed vertex lives on in the one it merged into
  return vertex_now(vc, v);
}

// Renames the moved vertices in their triangles and lists, for the local topology refresh, every triangle
// and vertex the cut changed.
LocalTopologyChange rename_moved_vertices(const Cut& C, const TriangleCompaction& tc, const VertexCompaction& vc,
                                          bool reached_boundary, Triangles& T) {
  LocalTopologyChange change;
  auto tri_now = [&](int32_t t) { return triangle_now(tc, T, t); };
  std::vector<int32_t>& changed = change.triangles;
  for (int32_t t : C.touched)
    if (const int32_t now = tri_now(t); now >= 0) changed.push_back(now);
  for (const auto& m : tc.moves) changed.push_back(m.second);

  // Rename the moved vertices in their triangles: those of the entry fan and the touched ones.
  for (const auto& [before, now] : vc.moves) {
    std::vector<int32_t> holders;
    if (before < C.n0)
      for (int32_t old : C.topo.fan(before))
        if (const int32_t t = tri_now(old); t >= 0) holders.push_back(t);
    holders.insert(holders.end(), changed.begin(), changed.end());
    for (int32_t t : holders)
      for (int32_t& c : T.tri[t])
        if (c == before) {
          c = now;
          changed.push_back(t);
        }
  }
  std::sort(changed.begin(), changed.end());
  changed.erase(std::unique(changed.begin(), changed.end()), changed.end());
  // Vertices whose fans changed: the corners of the changed triangles now, and the corners the touched
  // triangles had before the cut (a triangle that died or let go of a vertex leaves its old corners' fans).
  for (int32_t t : changed)
    for (int32_t c : T.tri[t]) change.vertices.push_back(c);
  for (const auto& [t, corners] : C.undo)
    for (int32_t c : corners)
      if (const int32_t now = vertex_now(vc, c); now >= 0) change.vertices.push_back(now);
  std::sort(change.vertices.begin(), change.vertices.end());
  change.vertices.erase(std::unique(change.vertices.begin(), change.vertices.end()), change.vertices.end());
  for (int32_t t : tc.dead)
    if (t < C.nt0) change.dead_triangles.push_back(t);
  std::sort(change.dead_triangles.begin(), change.dead_triangles.end());
  for (const auto& m : tc.moves)
    if (m.first < C.nt0) change.moved_triangles.push_back(m);
  change.pieces_may_split = reached_boundary;
  return change;
}

}  // namespace

CutResult cut_tear_segment(int32_t p, const Vec2& next, const Vec2& previous_direction, int32_t tear_id,
                           const RemeshParams& params, Sheet& sheet) {
  CutResult result;
  if (p < 0 || p >= sheet.verts.size() || !next.allFinite()) return result;

  // The fans of the sheet at entry; rebuilt locally if a caller changed triangles without a refresh.
  Topology local;
  const Topology* topo = &sheet.topo;
  if (sheet.topo.version != sheet.topology_version ||
      sheet.topo.vertex_count() != sheet.verts.size()) {
    std::vector<int32_t> piece;
    build_topology(sheet.tris.tri, sheet.verts.size(), local, piece);
    topo = &local;
  }
  if (topo->boundary_next[p] < 0) return result;  // p must be a boundary vertex

  Cut C(sheet, *topo);
  const Vec2 d0 = next - C.r(p);
  const Segment seg{p, next, tear_id, params};

  const WalkedPath walked = walk_and_split(seg, C);
  std::vector<int32_t> copy;
  if (walked.path.size() < 2 || !cut_along_path(seg, walked, C, copy)) {
    C.rollback();
    return result;
  }
  const bool reached_boundary = walked.reached_boundary;
  const std::vector<std::pair<int32_t, int32_t>> removed =
      remove_straight_start(CutStart{p, copy[0], previous_direction, d0}, params, C);

  const TriangleCompaction tc = compact_dead_triangles(C, sheet.tris);
  const VertexCompaction vc = compact_removed_vertices(removed, sheet.verts);
  const LocalTopologyChange change = rename_moved_vertices(C, tc, vc, reached_boundary, sheet.tris);

  for (Finger& f : sheet.fingers) {
    f.vertex = remapped_vertex(vc, f.vertex);
    // A pad's vertices are held, so never removed (remove_straight_start); a −1 would be dropped.
    size_t kept = 0;
    for (size_t j = 0; j < f.pad.size(); ++j) {
      const int32_t v = remapped_vertex(vc, f.pad[j]);
      if (v < 0) continue;
      f.pad[kept] = v;
      f.pad_offset[kept++] = f.pad_offset[j];
    }
    f.pad.resize(kept);
    f.pad_offset.resize(kept);
  }
  for (Tip& tp : sheet.tips) tp.vertex = remapped_vertex(vc, tp.vertex);
  if (topo == &sheet.topo) refresh_after_local_change(change, sheet);
  else refresh_after_topology_change(sheet);

  const int32_t tip = vertex_now(vc, walked.path.back());
  result.cut = true;
  result.reached_boundary = reached_boundary;
  result.tip_vertex = reached_boundary ? -1 : tip;
  result.end = sheet.verts.rest[tip];
  result.new_vertices = C.created;
  result.removed_vertices = static_cast<int32_t>(vc.gone.size());
  return result;
}

}  // namespace pt
