// Potential tearing points (paper §4.1, docs/tearing.md "Potential tearing points and fracture energy"):
// boundary vertices that are finger vertices, junction points, or have an inward angle in the pattern (every
// tear tip is one). Each gets its fracture energy Ef = c · T_fiber(u, v) · d_p (eq. 3), d_p = D at a tear
// tip, 1 elsewhere.
#pragma once

#include "components/sheet.hpp"
#include "systems/tearing/fiber_field.hpp"

namespace pt {

struct Candidate {
  int32_t vertex = -1;
  StartKind kind = StartKind::Inward;  // why it is a candidate (finger > junction > inward when several)
  int32_t tear = -1;                   // tear whose active tip it is, −1 otherwise
  double fracture_energy = 0;          // Ef, J/m²
};

// T_fiber at each vertex's pattern position, remembered between calls: the candidates are rebuilt after
// every propagation (docs/architecture.md "The frame") and a bilinear sample of the procedural field costs 4
// texels × 5 octaves of Perlin noise. An entry is used only while its vertex still sits at the same pattern
// point, so vertex renumbering by remeshing needs no invalidation. 24 bytes per vertex.
struct FiberSampleCache {
  std::vector<Vec2> uv;
  std::vector<double> value;  // fiber_sample at uv; NaN uv marks an empty slot
};

// Candidates in a deterministic order: active tips first (by tear id), then the others by vertex id.
// An active tip's kind is the start kind of its tear; a tip whose tear is not in `tears` takes its kind from
// its flags (finger > junction > inward), Inward when it has none of them. Finger vertices are those
// flagged kFinger or held by one of `fingers`; only boundary vertices are candidates, except active tips,
// which are always listed. The boundary vertices are the sheet's list (Topology::boundary_vertices,
// ascending; those flagged kBoundary, which the topology refresh keeps so) rather than every vertex, so the
// cost follows the boundary and the candidates, not the sheet (issue 3). `cache` is read and updated.
void find_candidates(const Vertices& verts, const std::vector<int32_t>& boundary_vertices, const std::vector<Tip>& tips,
                     const std::vector<Finger>& fingers, const std::vector<Tear>& tears, const Material& material,
                     const FiberField& fiber, std::vector<Candidate>& out, FiberSampleCache& cache);

}  // namespace pt
