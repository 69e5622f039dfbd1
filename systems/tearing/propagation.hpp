// Energy release rate, Griffith's test and the next tip (paper §5.2 eq. 6).
#pragma once

#include "components/sheet.hpp"
#include "systems/tearing/clustering.hpp"

namespace pt {

struct PropagationParams {
  double thickness = 1e-4;  // e
  double speed = 2e-7;      // k: p_next = p + k · Er · t
  double max_step = 0.01;   // m
  double min_step = 0;      // m; steps shorter than this are lengthened to it (avoid slivers)
  // Direction of the tear's last segment (unit, zero for a new tear). When |F̂̄_l + F̂̄_r| is below
  // sense_threshold (φ near π) the sense of t along the bisector line follows it.
  Vec2 previous_direction = Vec2::Zero();
  double sense_threshold = 0.3;
  // When non-zero, t is this direction (unit, pattern) instead of the clusters' bisector: the direction of
  // largest energy release from the crack driving force (systems/tearing/material_force.hpp). Er, φ and
  // Griffith's test still come from the clusters (eq. 6).
  Vec2 driving_direction = Vec2::Zero();
  double angle_tolerance = 1e-9;  // rad; t within this of a boundary direction at p is not "into" the sheet
};

struct PropagationDecision {
  double energy_release = 0;     // Er, J/m²
  double angle = 0;              // φ ∈ [0, π] between F̄_left and F̄_right
  Vec2 direction = Vec2::Zero(); // t (unit, pattern)
  bool into_material = false;    // t lies inside the interior angle at p
  bool griffith = false;         // Er ≥ Ef and both clusters non-empty (whatever t is)
  bool propagate = false;        // griffith and into_material
  Vec2 next = Vec2::Zero();      // p_next (pattern), only when propagate
};

// Er = (‖F_left‖ + ‖F_right‖) cos(φ/2) / e with φ the angle between the pattern pre-images;
// t = −normalize(F̄_l/‖F̄_l‖ + F̄_r/‖F̄_r‖), or params.driving_direction when that is non-zero. Er and φ
// are filled whenever the inputs are finite; t stays zero (no propagation) when a pre-image is zero, when
// the driving direction is not finite, or, for the bisector, when the pre-images are opposite (φ ≈ π,
// flat in-plane pull).
// `next` is not clipped to the sheet: a segment that leaves it is ended on the boundary by remeshing.
// t strictly inside the interior angle at boundary vertex p in the pattern (measured counter-clockwise from
// the direction to boundary_next; reflex angles such as a tear tip's included), `tolerance` rad from its edges.
bool direction_into_material(const Topology& topo, const std::vector<Vec2>& rest, int32_t p, const Vec2& t,
                             double tolerance);

// p_next = p + k · Er · t (§5.2), the step capped at max_step and lengthened to min_step (slivers).
Vec2 next_tip_position(const Vec2& p, const Vec2& t, double energy_release, const PropagationParams& params);

PropagationDecision decide_propagation(const ForceClusters& clusters, const Topology& topo,
                                       const std::vector<Vec2>& rest, int32_t p, double fracture_energy,
                                       const PropagationParams& params);

}  // namespace pt
