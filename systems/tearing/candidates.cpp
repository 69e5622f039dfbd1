// Potential tearing points (paper §4.1) and their fracture energy (paper eq. 3); docs/tearing.md
// "Potential tearing points and fracture energy".
//
// The list is short (~10 points) and rebuilt after every propagation, so it is a plain linear pass over
// the boundary vertices; what matters is that the order is deterministic, because the engine treats the
// candidates sequentially and each propagation changes the forces seen by the next
// (docs/architecture.md "The frame").
#include "systems/tearing/candidates.hpp"

#include <algorithm>
#include <limits>

namespace pt {
namespace {

// Why a boundary vertex is a candidate, by priority finger > junction > inward (the engine records the
// kind of the point a tear starts from). Returns false when it is none of the three.
bool candidate_kind(uint8_t flags, bool held_by_finger, StartKind& kind) {
  if ((flags & kFinger) || held_by_finger) {
    kind = StartKind::Finger;
    return true;
  }
  if (flags & kJunction) {
    kind = StartKind::Junction;
    return true;
  }
  if (flags & kInward) {
    kind = StartKind::Inward;
    return true;
  }
  return false;
}

// Eq. 3: Ef(p) = c · T_fiber(u, v) · d_p with d_p = D at a tear tip and 1 elsewhere.
// T_fiber at vertex v, from the cache when v has not moved in the pattern since it was sampled.
double fiber_at(const FiberField& fiber, const Vertices& verts, int32_t v, FiberSampleCache& cache) {
  const Vec2& uv = verts.rest[v];
  if (cache.uv[v] != uv) {
    cache.uv[v] = uv;
    cache.value[v] = fiber_sample(fiber, uv);
  }
  return cache.value[v];
}

double fracture_energy(const Material& material, double fiber_value, bool is_tip) {
  const double d = is_tip ? material.tip_damage : 1.0;
  // Eq. 3 with T_fiber lifted onto [fiber_floor, 1]: paper has weak spots but no holes, so the weakest
  // fibres keep a share of c (fiber_floor = 0 is the paper's eq. 3 exactly).
  const double t = material.fiber_floor + (1.0 - material.fiber_floor) * fiber_value;
  return material.fracture_c * t * d;
}

}  // namespace

// Nothing here is sized by the sheet: the engine calls this after every propagation, and its cost should
// follow the boundary and the candidates.
void find_candidates(const Vertices& verts, const std::vector<int32_t>& boundary_vertices, const std::vector<Tip>& tips,
                     const std::vector<Finger>& fingers, const std::vector<Tear>& tears, const Material& material,
                     const FiberField& fiber, std::vector<Candidate>& out, FiberSampleCache& cache) {
  out.clear();
  const int32_t nv = verts.size();
  if (static_cast<int32_t>(cache.uv.size()) != nv) {
    cache.uv.resize(nv, Vec2::Constant(std::numeric_limits<double>::quiet_NaN()));
    cache.value.resize(nv, 0.0);
  }
  // Per-call lists as long as the fingers and tips, kept per thread (this runs after every propagation).
  thread_local std::vector<int32_t> held_vertices, taken;
  thread_local std::vector<Tip> sorted;
  // A finger's vertex counts even if the kFinger flag has not been refreshed yet.
  held_vertices.clear();
  for (const Finger& f : fingers) held_vertices.push_back(f.vertex);
  std::sort(held_vertices.begin(), held_vertices.end());
  auto held = [&](int32_t v) { return std::binary_search(held_vertices.begin(), held_vertices.end(), v); };

  // Active tips first, by tear id: a tear in progress is continued before new tears are considered,
  // whatever the vertex numbering that remeshing left behind.
  sorted.assign(tips.begin(), tips.end());
  std::sort(sorted.begin(), sorted.end(), [](const Tip& a, const Tip& b) {
    return a.tear != b.tear ? a.tear < b.tear : a.vertex < b.vertex;
  });
  taken.clear();  // tip vertices listed, ascending
  for (const Tip& tip : sorted) {
    if (tip.vertex < 0 || tip.vertex >= nv || std::binary_search(taken.begin(), taken.end(), tip.vertex)) continue;
    taken.insert(std::upper_bound(taken.begin(), taken.end(), tip.vertex), tip.vertex);
    Candidate c;
    c.vertex = tip.vertex;
    c.tear = tip.tear;
    if (tip.tear >= 0 && tip.tear < static_cast<int32_t>(tears.size())) {
      c.kind = tears[tip.tear].start_kind;
    } else if (!candidate_kind(verts.flags[tip.vertex], held(tip.vertex), c.kind)) {
      c.kind = StartKind::Inward;  // every tear tip is an inward-angle point (paper §4.1)
    }
    c.fracture_energy = fracture_energy(material, fiber_at(fiber, verts, tip.vertex, cache), true);
    out.push_back(c);
  }

  // Then the other boundary points of the three kinds, by ascending vertex id. The tip and finger lists are
  // ascending too, so they are walked alongside (a search per vertex mispredicted its branches).
  size_t next_taken = 0, next_held = 0;
  auto consider = [&](int32_t v) {
    if (!(verts.flags[v] & kBoundary)) return;
    while (next_taken < taken.size() && taken[next_taken] < v) ++next_taken;
    if (next_taken < taken.size() && taken[next_taken] == v) return;
    while (next_held < held_vertices.size() && held_vertices[next_held] < v) ++next_held;
    const bool is_held = next_held < held_vertices.size() && held_vertices[next_held] == v;
    Candidate c;
    // The two lips of a tear turn apart, so their triangles always fall in different regions: that is
    // the tear itself, not a junction of the surface. A lip vertex is a candidate only as an inward
    // angle (a split vertex, where a branch may start, paper §5.3) or a finger.
    uint8_t flags = verts.flags[v];
    if (verts.tear[v] >= 0) flags &= static_cast<uint8_t>(~kJunction);
    if (!candidate_kind(flags, is_held, c.kind)) return;
    c.vertex = v;
    c.fracture_energy = fracture_energy(material, fiber_at(fiber, verts, v, cache), false);
    out.push_back(c);
  };
  for (int32_t v : boundary_vertices)
    if (v >= 0 && v < nv) consider(v);
}

}  // namespace pt
