// Crack driving force at a tear tip: the configurational (material) force of the membrane energy,
// computed by the domain form of the J-integral. An alternative to the bisector of eq. 4–6 for the
// direction a tip propagates in (the Scenario's "tearing": {"direction": "material_force"}).
//
// Why: the paper takes the direction that maximises the energy release rate Er (§4, after O'Keefe) to be
// the bisector of the two force clusters at p. Those are the forces of p's own fan of triangles, so on a
// coarse mesh each step's direction depends on the shape of that fan: measured over 16 meshes of Fig. 14
// and 15, the steps are 15–24° (median) off O'Keefe's bisector of PA and PB. The J-vector gives the
// direction of largest energy release itself, from the whole region around the tip:
//   G(e) = −dΠ/da for a virtual advance a of the tip along e (Parks 1974; Hellen 1975)
//        = J·e,  J = −Σ_t A_t Σ_t ∇q_t,  Σ = W I − Fᵀ P (Eshelby's energy-momentum tensor, 2x2),
// with q a weight that is 1 at p, falls linearly to 0 at `radius` in the pattern, and ∇q_t its constant
// gradient on triangle t (the equivalent domain integral, Shih, Moran & Nakamura 1986; Li, Shih &
// Needleman 1985). W and P = ∂W/∂F are the corotated membrane energy density of membrane_forces.hpp and
// its first Piola stress. Over a domain free of other singularities, J does not depend on the radius,
// nor much on the mesh: the domain spans many triangles, unlike the fan.
// Not included: bending (its configurational force, by finite differences of the stencils, changed the
// measured paths within their scatter), inertia and gravity (the domain integral assumes equilibrium).
#pragma once

#include "components/sheet.hpp"
#include "systems/physics/membrane_forces.hpp"

namespace pt {

struct DrivingForce {
  Vec2 j = Vec2::Zero();  // J, J/m² (per unit thickness): advancing the tip by da along unit e releases J·e da
  double radius = 0;      // the radius used (after the cap of domain_radius)
  int32_t triangles = 0;  // triangles with a non-zero ∇q
};

// The domain must not hold another singularity: a finger's vertex (a point load) or another tear's tip.
// Returns min(radius, distance from p to the nearest of `others`) in the pattern. The radius should span a
// few triangles: the default 0.04 m (TearingSettings) was the best of 0.02–0.06 m over the 16 meshes
// of Figs. 14 and 15 (~300 triangles on 15 x 21 cm).
double domain_radius(const std::vector<Vec2>& rest, int32_t p, const std::vector<int32_t>& others, double radius);

struct DrivingForceScratch {
  std::vector<int32_t> stamp;   // per vertex: the call that visited it
  std::vector<double> weight;   // per vertex visited by the current call: its q
  std::vector<int32_t> queue;   // vertices of the domain, in visiting order
  std::vector<int32_t> triangles;
  int32_t call = 0;
};

// J at vertex p over the triangles reached from p through vertices closer than `radius` (pattern), so a
// separate piece or the far side of a tear across open space is not part of the domain. Serial, summed
// in increasing triangle id: deterministic. Zero J when p is out of range or the radius is not positive.
DrivingForce crack_driving_force(const Vertices& verts, const Triangles& tris, const Topology& topo, int32_t p,
                                 double radius, const MembraneParams& params, DrivingForceScratch& scratch);

}  // namespace pt
