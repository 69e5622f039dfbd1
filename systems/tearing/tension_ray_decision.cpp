#include "systems/tearing/tension_ray_decision.hpp"

#include "systems/common/pattern_geometry.hpp"
#include "systems/common/topology.hpp"
#include "systems/tearing/clustering.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <limits>

namespace pt {

double start_wrap_excess(const Sheet& sheet, const TensionRays& rays, std::span<const LoadPoint> loads,
                         TensionRayDecisionScratch& scratch, bool* best_straight) {
  double best = std::numeric_limits<double>::infinity();
  if (best_straight) *best_straight = false;
  const PatternBoundary& boundary = scratch.rays.boundary;  // p's piece, built by compute_tension_rays
  for (const LoadRay& a : rays.rays) {
    if (a.side != 1 || !a.reachable) continue;
    scratch.targets.clear();
    for (const LoadRay& b : rays.rays)
      if (b.side == -1 && b.reachable) scratch.targets.push_back(loads[b.load].vertex);
    if (scratch.targets.empty()) return best;
    shortest_pattern_paths(boundary, sheet.topo, sheet.verts.rest, loads[a.load].vertex, scratch.targets,
                           scratch.rays.paths, scratch.between);
    size_t k = 0;
    for (const LoadRay& b : rays.rays) {
      if (b.side != -1 || !b.reachable) continue;
      const PatternPath& ab = scratch.between.paths[k++];
      if (!ab.reachable) continue;
      const double excess = a.path_length + b.path_length - ab.length;
      if (excess < best) {
        best = excess;
        if (best_straight) *best_straight = ab.straight;
      }
    }
  }
  return best;
}

namespace {

// Steps along t when it points into the material: p_next = p + k Er t, bounded.
void finish_decision(const Sheet& sheet, int32_t p, const PropagationParams& propagation, PropagationDecision& d) {
  d.into_material = direction_into_material(sheet.topo, sheet.verts.rest, p, d.direction, propagation.angle_tolerance);
  d.propagate = d.griffith && d.into_material;
  if (!d.propagate) return;
  d.next = next_tip_position(sheet.verts.rest[p], d.direction, d.energy_release, propagation);
  if (!d.next.allFinite()) {
    d.propagate = false;
    d.next = Vec2::Zero();
  }
}

// The world image of pattern direction `dir` at p, through the triangle of p's fan that the pattern
// direction `ahead` runs into from p (the material a tear along it cuts next; the nearest by angle when
// none contains it): F = [x1 − x0, x2 − x0] · rest_inv. A fan's mean F is no frame at a tip whose lips
// fold opposite ways. (membrane_forces.hpp's deformation_gradient times dir rounds differently, as
// (Ds rest_inv) dir, and that rounding moves a run of the 4-mesh checks: Ds (rest_inv dir) is kept.)
Vec3 world_direction_ahead(const Sheet& sheet, int32_t p, const Vec2& ahead, const Vec2& dir) {
  const auto& rest = sheet.verts.rest;
  int32_t best = -1;
  double best_gap = std::numeric_limits<double>::infinity();
  for (const int32_t t : sheet.topo.fan(p)) {
    const Tri& c = sheet.tris.tri[t];
    const int k = c[0] == p ? 0 : (c[1] == p ? 1 : 2);
    const Vec2 e1 = rest[c[(k + 1) % 3]] - rest[p], e2 = rest[c[(k + 2) % 3]] - rest[p];
    const double wedge = std::atan2(cross(e1, e2), e1.dot(e2));
    const double at = std::atan2(cross(e1, ahead), e1.dot(ahead));
    const double gap = at >= 0 && at <= wedge ? 0.0 : std::min(std::abs(at), std::abs(at - wedge));
    if (gap < best_gap) best_gap = gap, best = t;
  }
  if (best < 0) return Vec3::Zero();
  const Tri& c = sheet.tris.tri[best];
  const auto& x = sheet.verts.x;
  Eigen::Matrix<double, 3, 2> edges;
  edges << x[c[1]] - x[c[0]], x[c[2]] - x[c[0]];
  return edges * (sheet.tris.rest_inv[best] * dir);
}

// A start point lies on the load's path: within start_wrap of a shortest path between a left and a right
// load point of `rays` (docs/tearing.md, "Starts").
bool on_the_loads_path(const Sheet& sheet, const TensionRays& rays, const TensionRayDecisionParams& params,
                       TensionRayDecisionScratch& scratch) {
  return start_wrap_excess(sheet, rays, scratch.loads, scratch) <= params.start_wrap;
}

bool inward_corner(const Sheet& sheet, int32_t p) {
  return interior_pattern_angle(sheet.topo, sheet.verts.rest, p) > std::numbers::pi + 1e-9;
}

}  // namespace

PropagationDecision decide_edge_start(const Sheet& sheet, int32_t p, double fracture_energy,
                                      const PropagationParams& propagation, const MembraneParams& membrane,
                                      const TensionRayDecisionParams& params, TensionRayDecisionScratch& scratch) {
  PropagationDecision d;
  const EdgeTension edge =
      edge_tension(sheet.verts, sheet.tris, sheet.topo, p, params.edge_radius, membrane, scratch.edge);
  d.energy_release = std::max(0.0, edge.tension) * params.start_length / propagation.thickness;
  d.griffith = std::isfinite(d.energy_release) && d.energy_release >= fracture_energy;
  if (!d.griffith) return d;
  finger_load_points(sheet.fingers, scratch.loads);
  TensionRaysParams rp = params.rays;
  rp.thickness = propagation.thickness;
  TensionRays& rays = scratch.result;
  compute_tension_rays(sheet.verts.rest, sheet.tris.piece, sheet.topo, p, scratch.loads, rp, scratch.rays, rays);
  // What loads the edge is what the fingers holding p's piece pull: its tension over start_length cannot
  // carry more than their reactions in all, Er ≤ Σ‖R_j‖ / e, the bound of the rays' Er. Without it an edge
  // folded sharply while its fingers hold 0.1 N (a trouser's body as its legs tear apart) read a start
  // from the fold's membrane strain.
  double held = 0;
  for (const LoadRay& r : rays.rays) held += r.weight;
  if (!(held / propagation.thickness >= fracture_energy)) {
    d.griffith = false;
    return d;
  }
  // As at an inward corner, the edge opens only where the load between the two sides passes it: tension
  // far off that line (a border bent or curled between the hands, a lip beside a notch) is the sheet's
  // shape, not the pull that tears it. With the loads all on one side no path joins them, and the edge's
  // tension alone decides (a finger pinching the border). A path that bends round a reflex corner leaves
  // the start to that corner, where its load concentrates: a trouser leg's lip carries the leg's whole
  // pull under the compression relief, and started tears that cut the leg off.
  if (rays.left_count > 0 && rays.right_count > 0) {
    bool straight = false;
    const double excess = start_wrap_excess(sheet, rays, scratch.loads, scratch, &straight);
    if (excess > params.start_wrap || !straight) {
      d.griffith = false;
      return d;
    }
  }
  d.angle = rays.theta;
  // Across the edge's tension: the inward normal (the sheet lies left of prev → p → next).
  d.direction = rays.valid ? rays.direction : Vec2(-edge.tangent.y(), edge.tangent.x());
  finish_decision(sheet, p, propagation, d);
  return d;
}

PropagationDecision decide_by_tension_rays(const Sheet& sheet, int32_t p, double fracture_energy, bool is_start,
                                           const PropagationParams& propagation, const MembraneParams& membrane,
                                           const TensionRayDecisionParams& params, TensionRayDecisionScratch& scratch) {
  if (is_start && !inward_corner(sheet, p))
    return decide_edge_start(sheet, p, fracture_energy, propagation, membrane, params, scratch);
  PropagationDecision d;
  finger_load_points(sheet.fingers, scratch.loads);
  // Er ≤ Σ‖R_j‖ / e whatever the paths and the split (cos(θ/2) ≤ 1): most points of most frames stop here,
  // before any path is sought. NaN reactions stop here too.
  double total = 0;
  for (const LoadPoint& l : scratch.loads) total += l.reaction.norm();
  if (!(total / propagation.thickness >= fracture_energy)) return d;
  TensionRays& rays = scratch.result;
  TensionRaysParams rp = params.rays;
  rp.thickness = propagation.thickness;
  rp.normal = fan_normal(sheet.verts.x, sheet.tris.tri, sheet.topo.fan(p));  // "across the sheet" at p
  rp.previous_direction = propagation.previous_direction;
  compute_tension_rays(sheet.verts.rest, sheet.tris.piece, sheet.topo, p, scratch.loads, rp, scratch.rays, rays);
  if (rays.left_count == 0 || rays.right_count == 0) return d;
  d.angle = rays.theta;
  d.energy_release = rays.energy_release;
  // The sides pushed together in the plane open nothing (sensed_energy_release): "apart" is the left
  // normal of the split line b, where the left side's loads lie, seen in the material ahead of p.
  if (rays.direction.squaredNorm() > 0)
    d.energy_release = sensed_energy_release(
        rays, rp.normal,
        world_direction_ahead(sheet, p, rays.direction, Vec2(-rays.bisector.y(), rays.bisector.x())),
        rp.thickness);
  d.griffith = std::isfinite(d.energy_release) && d.energy_release >= fracture_energy;
  if (!d.griffith) return d;
  if (is_start && !on_the_loads_path(sheet, rays, params, scratch)) {
    d.griffith = false;
    return d;
  }
  if (rays.valid) {
    d.direction = rays.direction;
  } else {
    // The J-vector over the tip's surroundings, its domain kept clear of fingers and other tips.
    scratch.singular.clear();
    for (const Finger& f : sheet.fingers) scratch.singular.push_back(f.vertex);
    for (const Tip& t : sheet.tips) scratch.singular.push_back(t.vertex);
    const double radius = domain_radius(sheet.verts.rest, p, scratch.singular, params.driving_force_radius);
    const DrivingForce force =
        crack_driving_force(sheet.verts, sheet.tris, sheet.topo, p, radius, membrane, scratch.driving);
    if (!(force.j.squaredNorm() > 0) || !force.j.allFinite()) return d;
    d.direction = force.j.normalized();
  }
  finish_decision(sheet, p, propagation, d);
  return d;
}

}  // namespace pt
