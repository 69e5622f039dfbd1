// Tear direction and energy release at a boundary vertex from the pulling points themselves: the
// paper's two virtual fingers (Schreck et al. 2017, §5.1–5.2, eqs. 4–6) built from the load points of
// p's piece instead of the forces of p's fan, so the direction does not depend on the mesh around p.
//
// Each load point A_j (a finger's held vertex, weight w_j = ‖R_j‖ of its reaction) pulls p along the
// shortest path from p to A_j inside the torn pattern; g_j is that path's direction at p (straight at
// A_j when nothing is in the way, else at the first tear tip or notch corner the path bends around).
// The g_j are split in two sides by eq. 4's iterated line through p, each side gives a mean direction
// u_L, u_R, and the tear runs along their bisector, t = ±normalize(u_L + u_R): O'Keefe's rule, which for
// two fingers A, B is the tangent at p of the hyperbola |PA| − |PB| = const (O'Keefe 1994). A tip keeps
// its way along that line; a start runs away from the loads unless only towards them is into the
// material. Er = ‖P_L − P_R‖ cos(θ/2) / e (eq. 6's form), P_L, P_R the sides' summed reactions and θ the
// angle between u_L and u_R: equal and opposite pulls give eq. 6's (F_L + F_R).
// Only rest positions, the boundary and the reactions enter: on two meshes of the same torn outline
// the result is the same.
#pragma once

#include "components/sheet.hpp"
#include "systems/tearing/pattern_paths.hpp"

#include <span>
#include <vector>

namespace pt {

struct LoadPoint {
  int32_t vertex = -1;           // held vertex: A_j = rest[vertex]
  Vec3 reaction = Vec3::Zero();  // R_j, N (3D); w_j = ‖R_j‖
  int32_t hand = -1;             // the hand whose fingers move with this one, −1 none (a hand of its own)
};

// The fingers holding a vertex now, in finger order.
void finger_load_points(const std::vector<Finger>& fingers, std::vector<LoadPoint>& out);

struct TensionRaysParams {
  double thickness = 1e-4;       // e, m
  int32_t max_iterations = 20;   // of eq. 4's split
  double opposite_tolerance = 1e-9;  // |u_L + u_R| below this: no direction (θ ≈ π)
  double angle_tolerance = 1e-9;     // rad: t this close to a boundary direction at p is not into the material
  Vec2 previous_direction = Vec2::Zero();  // a tip's last segment (unit), zero at a start: orients t
  // The length over which a load's bearing is read (see LoadRay::bearing): notch features smaller than
  // this (a 1 mm-wide slit's flat end) do not steer the tear or weaken Er.
  double bearing_length = 0.005;  // m
  // The least weight of the in-plane pull (Er below): O'Keefe's cos(θ/2) vanishes for pulls exactly
  // opposite across the tip, but a crack pulled open in its plane does open (mode I), at several times
  // the force a tear out of the plane needs.
  double opening_floor = 0.1;
  // Keep each hand's fingers (LoadPoint::hand) on one side of the split.
  bool hands_whole = true;
  // The sheet's unit normal at p (3D), or zero (every pull read as in the plane): the part of the opening
  // force across the sheet tears the lips apart as a trouser's legs, whatever the bearings (Er below).
  Vec3 normal = Vec3::Zero();
  PatternPathParams paths;
};

enum class TensionRaysStatus : uint8_t {
  Valid = 0,
  NotBoundary,      // p out of range or not a boundary vertex
  EmptySide,        // no load point on one of the two sides
  Opposite,         // u_L + u_R ≈ 0: in-plane pulls from opposite sides (θ ≈ π)
  NotIntoMaterial,  // t not strictly inside p's interior angle
};

// One load point of p's piece.
struct LoadRay {
  int32_t load = -1;               // index into the loads given
  Vec2 direction = Vec2::Zero();   // g_j (unit, pattern): the path's first segment, which tells the side
  // The load's bearing, what u_L, u_R and θ are made of: the direction from p to the path's first corner
  // at least bearing_length away (the load point itself when none is). At a blunt notch's corner the path
  // to the far leg first runs along the notch's end, across the tear's line; its bearing is that leg's.
  Vec2 bearing = Vec2::Zero();
  double weight = 0;               // w_j = ‖R_j‖
  Vec3 reaction = Vec3::Zero();    // R_j
  double path_length = 0;          // m
  int32_t first_corner = -1;       // vertex the path first bends at, −1 when straight
  double wedge_angle = 0;          // of g_j in p's interior angle, from the edge to boundary_next, rad
  int32_t side = 0;                // +1 left (cross(b, g) > 0), −1 right, 0 neither (see below)
  bool straight = false;
  bool reachable = false;          // a path was found (else the load point is not used)
};

struct TensionRays {
  bool valid = false;
  TensionRaysStatus status = TensionRaysStatus::NotBoundary;
  Vec2 direction = Vec2::Zero();   // t (unit, pattern); set whenever both sides exist and u_L + u_R ≠ 0
  double theta = 0;                // angle between u_L and u_R, [0, π]
  // F_L = Σ_left w_j, F_R = Σ_right w_j: the magnitudes, as eq. 6 sums ‖F_l‖ + ‖F_r‖ of the paper's
  // virtual fingers, so two fingers on one side pulling along different paths add up.
  double left_force = 0, right_force = 0;
  double opening_force = 0;        // ‖Σ_left R_j − Σ_right R_j‖: what pulls the two sides apart, N
  Vec3 opening = Vec3::Zero();     // Σ_left R_j − Σ_right R_j = P_L − P_R, N
  int32_t left_count = 0, right_count = 0;
  Vec2 left_direction = Vec2::Zero(), right_direction = Vec2::Zero();  // u_L, u_R (unit)
  double in_plane = 0;             // the in-plane pull's weight, max(cos(θ/2), opening_floor)
  double energy_release = 0;       // Er = ‖P_L − P_R‖ · in_plane / e (in-plane pulls), J/m²
  Vec2 bisector = Vec2::Zero();    // final b of the split (unit)
  int32_t iterations = 0;          // split iterations after b0
  int32_t other_piece = 0;         // load points ignored: on another piece or released (vertex < 0)
  int32_t ignored = 0;             // load points of p's piece ignored: at p itself, zero weight, or no path
  std::vector<LoadRay> rays;       // the load points of p's piece with a weight, in the loads' order
  PatternPaths paths;              // their paths (rays[i] ↔ paths.paths[i])
};

struct TensionRaysScratch {
  PatternBoundary boundary;
  PatternPathScratch paths;
  std::vector<int32_t> targets;
  std::vector<int32_t> sides;                 // per ray, during the split
  std::vector<double> hand_left, hand_right;  // per hand, its weight on each side of the split
};

// Sides: g_j is left of the split line b when it lies further counter-clockwise than b in p's interior
// angle (measured from the edge to boundary_next): the sign of cross(b, g_j) while they are less than π
// apart; a path leaving back along a lip (a finger on a lip, a path round a tear's kink) stays on that
// lip's side. Directions exactly along b are on neither side.
//
// The tension rays at boundary vertex p (a tear tip or a start point) for `loads` (only those on p's
// piece count). Invalid (status says why; the caller falls back to the J-vector of
// systems/tearing/material_force.hpp) when a side is empty, u_L + u_R ≈ 0, or t does not point into the
// material. Serial and in a fixed order: deterministic. No allocation once `scratch` and `out` have
// served a sheet of that size.
void compute_tension_rays(const std::vector<Vec2>& rest, const std::vector<int32_t>& piece, const Topology& topo,
                          int32_t p, std::span<const LoadPoint> loads, const TensionRaysParams& params,
                          TensionRaysScratch& scratch, TensionRays& out);

// Er of `rays` with the sense of the pull in the sheet's plane (docs/tearing.md, "Direction and Er"). The
// in-plane part of Δ = P_L − P_R splits along `apart`, the direction in which the left side moves away from
// the tear's line (in the sheet's plane at p, whose unit normal is `normal`), and along that line. Pushing
// the two sides together closes the tear, so only a pull apart counts; the pull along the line (a shear)
// counts whatever its sense:
//   Er = sqrt((Δ·n)² + c² (max(0, Δ·a)² + (Δ·h)²)) / e,   c = rays.in_plane = max(cos(θ/2), opening_floor),
// a = `apart` made a unit vector in the plane, h = n × a. Where Δ·a ≥ 0 it equals compute_tension_rays'
// Er. `apart` (any length) parallel to the normal or zero leaves that Er.
double sensed_energy_release(const TensionRays& rays, const Vec3& normal, const Vec3& apart, double thickness);

}  // namespace pt
