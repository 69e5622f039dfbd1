// The tension along the sheet's edge at a boundary point, read over a physical length (docs/tearing.md):
// what starts a tear at a point that no tension ray wraps around — a twisted or crumpled border (paper
// Figs. 13, 18), the edge at a pinching finger — is the edge itself pulled apart along its length.
//
// N_tt = tᵀ σ̄ t, with t the edge's tangent at p in the pattern and σ̄ the membrane stress (N/m, the rest
// frame's Kirchhoff-like stress e ∂W/∂E of membrane_forces.hpp) averaged by rest area over the triangles with
// a corner within `radius` of p (at least p's fan), so the reading does not shrink with the mesh's triangles.
#pragma once

#include "components/sheet.hpp"
#include "systems/physics/membrane_forces.hpp"

namespace pt {

struct EdgeTensionScratch {
  std::vector<int32_t> stamp, queue, triangles;
  int32_t call = 0;
};

struct EdgeTension {
  double tension = 0;          // N_tt, N/m (negative: compressed along the edge)
  Vec2 tangent = Vec2::Zero(); // t, unit, pattern: from the previous boundary vertex to the next
  int32_t triangles = 0;       // triangles averaged
};

// Zero tension when p is not a boundary vertex.
EdgeTension edge_tension(const Vertices& verts, const Triangles& tris, const Topology& topo, int32_t p,
                         double radius, const MembraneParams& membrane, EdgeTensionScratch& scratch);

// The membrane stress of one triangle in the rest frame, N/m: e (2μE + λ tr(E) I + τ_lim), E = sym(RᵀF) − I.
Mat2 triangle_membrane_stress(const std::vector<Vec3>& x, const Tri& tri, const Mat2& rest_inv,
                              const MembraneParams& membrane);

}  // namespace pt
