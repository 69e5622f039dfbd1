// Tension rays: the paper's virtual fingers (eqs. 4–6) from the load points' shortest paths in the
// pattern, and O'Keefe's bisector rule for the tear direction.
#include "systems/tearing/tension_rays.hpp"

#include "systems/common/pattern_geometry.hpp"
#include "systems/common/topology.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <numbers>

namespace pt {
namespace {

constexpr double kTwoPi = 2 * std::numbers::pi;

double ccw_angle(const Vec2& a, const Vec2& b) {
  double angle = std::atan2(cross(a, b), a.dot(b));
  if (angle < 0) angle += kTwoPi;
  return angle;
}

Vec2 rotate(const Vec2& v, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  return Vec2(c * v.x() - s * v.y(), s * v.x() + c * v.y());
}

// The interior bisector at boundary vertex v: half its interior angle counter-clockwise from the edge to
// boundary_next (the material is on the left). Defined for any angle, slit tips (2π) included.
Vec2 interior_bisector(const Topology& topo, const std::vector<Vec2>& rest, int32_t v) {
  const Vec2 next = (rest[topo.boundary_next[v]] - rest[v]).normalized();
  return rotate(next, 0.5 * interior_pattern_angle(topo, rest, v));
}

// Angle of the path's first segment in p's interior angle, counter-clockwise from the edge to
// boundary_next, in [0, interior]. At a slit's tip both lips leave in one direction (0 and 2π): the lip
// the segment runs along tells which, found by walking each lip from p over the vertices on the segment.
double wedge_angle(const PatternPaths& paths, const PatternPath& path, const Topology& topo,
                   const std::vector<Vec2>& rest, int32_t p, double interior, double tol, double angle_tol) {
  const Vec2& pp = rest[p];
  double alpha = ccw_angle(rest[topo.boundary_next[p]] - pp, path.first_direction);
  if (alpha > interior) alpha = alpha - interior < kTwoPi - alpha ? interior : 0.0;  // rounding at the ends
  const bool at_next = alpha <= angle_tol, at_prev = alpha >= interior - angle_tol;
  if (at_next == at_prev) {
    if (!at_next) return alpha;
  } else {
    if (interior < kTwoPi - 2 * angle_tol) return alpha;  // the two lips leave in different directions
  }
  const int32_t q = paths.point_vertex[path.point_begin];
  const Vec2 d = rest[q] - pp;
  const double length = d.norm();
  auto reaches = [&](const std::vector<int32_t>& step) {
    int32_t v = step[p];
    for (int32_t k = 0; k < topo.vertex_count() && v >= 0 && v != p; ++k, v = step[v]) {
      if (v == q) return true;
      const Vec2 pv = rest[v] - pp;
      if (std::abs(cross(d, pv)) > tol * length || pv.dot(d) >= length * length) return false;
    }
    return false;
  };
  if (reaches(topo.boundary_next)) return 0.0;
  if (reaches(topo.boundary_prev)) return interior;
  return alpha;
}

// Weighted sums of the two sides' directions and magnitudes for the current sides.
struct SideSums {
  Vec2 left = Vec2::Zero(), right = Vec2::Zero();
  double left_force = 0, right_force = 0;
  Vec3 left_pull = Vec3::Zero(), right_pull = Vec3::Zero();
  int32_t left_count = 0, right_count = 0;
};

SideSums sum_sides(const std::vector<LoadRay>& rays) {
  SideSums s;
  for (const LoadRay& r : rays) {
    if (r.side > 0) {
      s.left += r.weight * r.bearing;
      s.left_force += r.weight;
      s.left_pull += r.reaction;
      ++s.left_count;
    } else if (r.side < 0) {
      s.right += r.weight * r.bearing;
      s.right_force += r.weight;
      s.right_pull += r.reaction;
      ++s.right_count;
    }
  }
  return s;
}

// The direction from p to the first point of `path` (its corners, then the target) at least `length`
// from p, the target when none is.
Vec2 load_bearing(const PatternPaths& paths, const PatternPath& path, const Vec2& p, double length) {
  if (path.point_end <= path.point_begin) return path.first_direction;
  Vec2 d = Vec2::Zero();
  for (int32_t k = path.point_begin; k < path.point_end; ++k) {
    d = paths.points[k] - p;
    if (d.norm() >= length) break;
  }
  const double n = d.norm();
  return n > 0 ? Vec2(d / n) : path.first_direction;
}

}  // namespace

void finger_load_points(const std::vector<Finger>& fingers, std::vector<LoadPoint>& out) {
  out.clear();
  for (const Finger& f : fingers)
    if (f.vertex >= 0 && !f.released) out.push_back(LoadPoint{f.vertex, f.reaction, f.hand});
}

void compute_tension_rays(const std::vector<Vec2>& rest, const std::vector<int32_t>& piece, const Topology& topo,
                          int32_t p, std::span<const LoadPoint> loads, const TensionRaysParams& params,
                          TensionRaysScratch& scratch, TensionRays& out) {
  out.valid = false;
  out.status = TensionRaysStatus::NotBoundary;
  out.direction = out.left_direction = out.right_direction = out.bisector = Vec2::Zero();
  out.theta = out.left_force = out.right_force = out.energy_release = out.in_plane = 0;
  out.left_count = out.right_count = out.iterations = out.other_piece = out.ignored = 0;
  out.rays.clear();
  out.paths.paths.clear();
  out.paths.points.clear();
  out.paths.point_vertex.clear();
  out.paths.visibility_tests = 0;
  if (p < 0 || p >= topo.vertex_count() || p >= static_cast<int32_t>(rest.size()) || topo.boundary_next[p] < 0)
    return;
  const int32_t p_piece = vertex_piece(topo, piece, p);
  if (p_piece < 0) return;

  // The load points of p's piece, pulling (w_j > 0), other than p itself.
  scratch.targets.clear();
  for (int32_t j = 0; j < static_cast<int32_t>(loads.size()); ++j) {
    const LoadPoint& l = loads[j];
    if (l.vertex < 0 || l.vertex >= topo.vertex_count() || vertex_piece(topo, piece, l.vertex) != p_piece) {
      ++out.other_piece;
      continue;
    }
    const double w = l.reaction.norm();
    if (l.vertex == p || !(w > 0) || !std::isfinite(w)) {
      ++out.ignored;
      continue;
    }
    LoadRay r;
    r.load = j;
    r.weight = w;
    r.reaction = l.reaction;
    out.rays.push_back(r);
    scratch.targets.push_back(l.vertex);
  }

  // g_j: first direction of the shortest path from p to A_j in the torn pattern.
  build_pattern_boundary(topo, rest, piece, p_piece, params.paths, scratch.boundary);
  shortest_pattern_paths(scratch.boundary, topo, rest, p, scratch.targets, scratch.paths, out.paths);
  const int32_t n = static_cast<int32_t>(out.rays.size());
  for (int32_t i = 0; i < n; ++i) {
    const PatternPath& path = out.paths.paths[i];
    LoadRay& r = out.rays[i];
    r.reachable = path.reachable;
    r.straight = path.straight;
    r.path_length = path.length;
    r.first_corner = path.first_corner;
    r.direction = r.bearing = path.first_direction;
    if (!path.reachable) ++out.ignored;
    else r.bearing = load_bearing(out.paths, path, rest[p], params.bearing_length);
  }

  // Eq. 4 in the pattern: b0 the interior bisector at p, then b_i the bisector line of the two sides'
  // mean directions, oriented so each side keeps its label, until the split no longer changes. The side
  // of g_j is the side of the line b through p, cross(b, g_j) > 0 on the left, told by the angles in
  // p's interior angle: left when g_j is further counter-clockwise from the edge to boundary_next than b.
  // That is the sign of cross(b, g_j) whenever the two are less than π apart, and keeps the loads of each
  // lip on its own side when g_j runs back along a lip (a finger on a lip, a path round a tear's kink).
  const Vec2& pp = rest[p];
  const double tol = scratch.boundary.tolerance;
  const double interior = interior_pattern_angle(topo, rest, p);
  const Vec2 next_edge = rest[topo.boundary_next[p]] - pp;
  for (int32_t i = 0; i < n; ++i) {
    LoadRay& r = out.rays[i];
    if (r.reachable)
      r.wedge_angle = wedge_angle(out.paths, out.paths.paths[i], topo, rest, p, interior, tol,
                                  params.paths.angle_tolerance);
  }
  Vec2 b = interior_bisector(topo, rest, p);
  std::vector<int32_t>& sides = scratch.sides;
  sides.resize(n);
  auto split = [&](const Vec2& line) {
    const double beta = ccw_angle(next_edge, line);
    const bool inside = beta > 0 && beta < interior;
    for (int32_t i = 0; i < n; ++i) {
      const LoadRay& r = out.rays[i];
      int32_t side = 0;
      if (r.reachable) {
        // b outside the material (pulls from ahead): the plane's sides; t will not be valid anyway.
        const double c = inside ? r.wedge_angle - beta : cross(line, r.direction);
        side = c > 1e-12 ? 1 : (c < -1e-12 ? -1 : 0);
      }
      sides[i] = side;
    }
    // A hand's fingers move as one body, so the tear does not run between them: a hand the line splits
    // goes whole to the side that holds more of its weight (the left on a tie). Without it fig12's tear,
    // started by the right hand, turned between that hand's two fingers towards the border it started
    // from (docs/tearing.md, "Direction and Er at a tip").
    if (params.hands_whole) {
      std::vector<double>& left = scratch.hand_left;
      std::vector<double>& right = scratch.hand_right;
      left.clear();
      right.clear();
      for (int32_t i = 0; i < n; ++i) {
        const int32_t hand = loads[out.rays[i].load].hand;
        if (hand < 0) continue;
        if (static_cast<size_t>(hand) >= left.size()) {
          left.resize(hand + 1, 0.0);
          right.resize(hand + 1, 0.0);
        }
        if (sides[i] > 0) left[hand] += out.rays[i].weight;
        if (sides[i] < 0) right[hand] += out.rays[i].weight;
      }
      for (int32_t i = 0; i < n; ++i) {
        const int32_t hand = loads[out.rays[i].load].hand;
        if (hand < 0 || sides[i] == 0 || left[hand] == 0 || right[hand] == 0) continue;
        sides[i] = left[hand] >= right[hand] ? 1 : -1;
      }
    }
    bool changed = false;
    for (int32_t i = 0; i < n; ++i) {
      changed |= sides[i] != out.rays[i].side;
      out.rays[i].side = sides[i];
    }
    return changed;
  };
  split(b);
  SideSums s = sum_sides(out.rays);
  while (out.iterations < params.max_iterations && s.left_count > 0 && s.right_count > 0) {
    const Vec2 m = s.left.normalized() - s.right.normalized();
    const double ml = m.norm();
    if (!(ml > 1e-12)) break;  // the two sides pull the same way: no line between them
    // The normal of u_L − u_R is the bisector line of u_L and u_R (unit vectors); this sense keeps
    // cross(b, u_L) = (u_L − u_R)·u_L / |u_L − u_R| > 0, so the left side stays left.
    b = Vec2(m.y(), -m.x()) / ml;
    ++out.iterations;
    const bool changed = split(b);
    s = sum_sides(out.rays);
    if (!changed) break;
  }
  out.bisector = b;
  out.left_count = s.left_count;
  out.right_count = s.right_count;
  out.left_force = s.left_force;
  out.right_force = s.right_force;
  if (s.left_count == 0 || s.right_count == 0) {
    out.status = TensionRaysStatus::EmptySide;
    return;
  }

  // Eq. 6 and O'Keefe's rule: t = ±normalize(u_L + u_R), Er = ‖P_L − P_R‖ cos(θ/2) / e with P the sides'
  // summed reactions: what pulls the two sides apart. Equal and opposite pulls give eq. 6's F_L + F_R; a
  // load both sides carry the same way (a sheet held up against its weight) opens nothing.
  // O'Keefe's cos(θ/2) is the geometry of pulls in the sheet's plane. The part of P_L − P_R across the
  // sheet at p (its normal n, when given) tears the lips apart as a trouser's legs are, whatever the
  // bearings, so only the in-plane part is weighted: Er = ‖(Δ·n) n + cos(θ/2) (Δ − (Δ·n) n)‖ / e with
  // Δ = P_L − P_R (the two parts are orthogonal). A hand lifting one side of a notch beside it (θ near π)
  // then tears it as a trouser's leg does, at F ≈ Ef·e, not at Ef·e / cos(θ/2).
  // cos(θ/2) has a floor, params.opening_floor: pulls exactly opposite across the tip open it in the
  // plane (mode I), which paper resists far better than a tear out of it, but not forever. Without it
  // a tip level with two fingers pulling apart (demo's inner fingers, 1 mm off their line) read Er ≈ 0
  // and stalled while a substep loaded the strip by 4 N (docs/tearing.md, "Direction and Er").
  const Vec2 ul = s.left.normalized(), ur = s.right.normalized();
  out.left_direction = ul;
  out.right_direction = ur;
  out.theta = std::atan2(std::abs(cross(ul, ur)), ul.dot(ur));
  out.opening = s.left_pull - s.right_pull;
  out.opening_force = out.opening.norm();
  const Vec3& open = out.opening;
  const double across = params.normal.squaredNorm() > 0 ? open.dot(params.normal) : 0.0;
  out.in_plane = std::max(std::cos(0.5 * out.theta), params.opening_floor);
  const double along = (open - across * params.normal).norm() * out.in_plane;
  out.energy_release = std::sqrt(across * across + along * along) / params.thickness;
  const Vec2 sum = ul + ur;
  const double sum_norm = sum.norm();
  if (!(sum_norm > params.opposite_tolerance)) {
    out.status = TensionRaysStatus::Opposite;
    return;
  }
  // The tear runs along the bisector's line, the hyperbola's tangent at p. Which way: at a tip the way
  // it already runs (a tear passing between its two fingers keeps going), at a start away from the loads
  // (Fig. 7) unless only towards them is into the material (fingers beyond a notch's apex).
  const Vec2 away = -sum / sum_norm;
  const auto into_material = [&](const Vec2& t) {
    const double at = ccw_angle(next_edge, t);
    return at > params.angle_tolerance && at < interior - params.angle_tolerance;
  };
  const Vec2& previous = params.previous_direction;
  if (previous.squaredNorm() > 0)
    out.direction = away.dot(previous) >= 0 ? away : Vec2(-away);
  else
    out.direction = !into_material(away) && into_material(-away) ? Vec2(-away) : away;
  if (!into_material(out.direction)) {
    out.status = TensionRaysStatus::NotIntoMaterial;
    return;
  }
  out.valid = true;
  out.status = TensionRaysStatus::Valid;
}

double sensed_energy_release(const TensionRays& rays, const Vec3& normal, const Vec3& apart, double thickness) {
  const Vec3 a = (apart - apart.dot(normal) * normal).normalized();
  if (!a.allFinite() || !(a.squaredNorm() > 0.5)) return rays.energy_release;
  const Vec3 h = normal.cross(a);
  const Vec3& d = rays.opening;
  const double across = d.dot(normal);
  const double pull = std::max(0.0, d.dot(a)), shear = d.dot(h);
  const double c = rays.in_plane;
  return std::sqrt(across * across + c * c * (pull * pull + shear * shear)) / thickness;
}

}  // namespace pt
