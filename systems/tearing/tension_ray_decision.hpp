// Griffith's decision and the direction of a potential tearing point from its tension rays (docs/tearing.md):
// the paper's two virtual fingers (§5.1, eqs. 4–6) taken as the load points of the piece, each pulling along
// its shortest path in the torn pattern (systems/tearing/tension_rays.hpp), instead of the forces of the
// point's own fan of triangles, which scale with the fan's size.
//
// - Er = ‖P_L − P_R‖ cos(θ/2) / e (eq. 6's form) with P_L, P_R the fingers' summed reactions on either
//   side, what pulls the sides apart, so it does not depend on the mesh; Griffith (eq. 1): propagate iff
//   Er ≥ Ef.
// - t = ±normalize(u_L + u_R), O'Keefe's bisector: for two fingers, the tangent of the hyperbola
//   |PA| − |PB| = const. Where the rays give no direction into the material (one side empty, the pulls
//   opposite, t out of the sheet) t is the crack driving force, the J-vector (systems/tearing/material_force.hpp).
// - At an inward corner (a notch, the kink of an old tear) a tear starts only where the load between the
//   two sides passes: p must lie on a shortest path between a load point on its left and one on its right,
//   within `start_wrap` (a physical length): d(A, p) + d(p, B) − d(A, B) ≤ start_wrap. The tension that
//   joins two pulling fingers wraps around a notch's apex but passes by its flanks; without this, every
//   boundary point between two fingers would read the same Er.
// - Elsewhere on the edge (a junction, a pinching finger, a twisted or crumpled border) no ray wraps, and
//   what starts a tear is the edge pulled apart along its length: Er = N_tt · start_length / e with N_tt
//   the tension along the edge over a physical disc (systems/tearing/edge_tension.hpp), i.e. a tear starts
//   when the edge's tension over start_length carries the force of a trouser start, and, when loads lie on
//   both sides, only within start_wrap of the load's path between them, as at an inward corner, and only
//   where that path is straight: a path that bends round a reflex corner (a notch's or a tear's tip)
//   concentrates its load there, and a lip beside the notch carries it without concentration. Its
//   direction is the rays' when they give one, else straight into the sheet, across the tension.
#pragma once

#include "components/sheet.hpp"
#include "systems/tearing/material_force.hpp"
#include "systems/physics/membrane_forces.hpp"
#include "systems/tearing/propagation.hpp"
#include "systems/tearing/edge_tension.hpp"
#include "systems/tearing/tension_rays.hpp"

namespace pt {

struct TensionRayDecisionParams {
  TensionRaysParams rays;
  double start_wrap = 0.003;          // m: how far off the path between two loads a start may lie
  double start_length = 0.01;         // m: the edge length whose tension starts a tear at a convex point
  double edge_radius = 0.005;         // m: the disc over which the edge's tension is read
  double driving_force_radius = 0.04; // m, the J-vector's domain (fallback direction)
};

struct TensionRayDecisionScratch {
  std::vector<LoadPoint> loads;
  TensionRaysScratch rays;
  TensionRays result;
  PatternPaths between;        // shortest paths between the two sides' loads (the start test)
  std::vector<int32_t> targets;
  DrivingForceScratch driving;
  EdgeTensionScratch edge;
  std::vector<int32_t> singular;
};

// Why a start point is (not) on the load's path: the smallest d(A, p) + d(p, B) − d(A, B) over left loads
// A and right loads B of the tension rays `rays` at p, m (infinity when no pair is connected); with
// `best_straight`, whether the shortest path A → B of that pair is straight (bends at no reflex corner).
double start_wrap_excess(const Sheet& sheet, const TensionRays& rays, std::span<const LoadPoint> loads,
                         TensionRayDecisionScratch& scratch, bool* best_straight = nullptr);

// A start at a convex or straight boundary point p, from the tension along the edge (see above).
PropagationDecision decide_edge_start(const Sheet& sheet, int32_t p, double fracture_energy,
                                      const PropagationParams& propagation, const MembraneParams& membrane,
                                      const TensionRayDecisionParams& params, TensionRayDecisionScratch& scratch);

// The decision at candidate vertex p (Ef its fracture energy; `is_start`: p is not an active tip).
// `previous` is the tip's last direction (zero for a start). `membrane` is the energy of the J-vector fallback.
PropagationDecision decide_by_tension_rays(const Sheet& sheet, int32_t p, double fracture_energy, bool is_start,
                                           const PropagationParams& propagation, const MembraneParams& membrane,
                                           const TensionRayDecisionParams& params, TensionRayDecisionScratch& scratch);

}  // namespace pt
