// Tension rays: the paper's virtual fingers (eqs. 4–6) from the load points' shortest paths in the
// pattern, and O'Keefe's bisector rule for the tear direction.
#include "systems/tearing/tension_rays.hpp"

#include "systems/topology.hpp"

#include <cmath>
#include <numbers>

namespace pt {
namespace {

constexpr double kTwoPi = 2 * std::numbers::pi;

double cross(const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); }

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

// The side of a path for split line b through p: sign of cross(b, q − p) for its first point q off the
// line, else of cross(b, material direction at its target) (eq. 4 for directions on the line).
int32_t path_side(const PatternPaths& paths, const PatternPath& path, const Topology& topo,
                  const std::vector<Vec2>& rest, const Vec2& p, const Vec2& b, double tol) {
  for (int32_t i = path.point_begin; i < path.point_end; ++i) {
    const double c = cross(b, paths.points[i] - p);
    if (c > tol) return 1;
    if (c < -tol) return -1;
  }
  const int32_t target = paths.point_vertex[path.point_end - 1];
  if (topo.boundary_next[target] < 0) return 0;
  const double c = cross(b, interior_bisector(topo, rest, target));
  return c > 1e-12 ? 1 : (c < -1e-12 ? -1 : 0);
}

// Weighted sums of the two sides' directions and magnitudes for the current sides.
struct SideSums {
  Vec2 left = Vec2::Zero(), right = Vec2::Zero();
  double left_force = 0, right_force = 0;
  int32_t left_count = 0, right_count = 0;
};

SideSums sum_sides(const std::vector<LoadRay>& rays) {
  SideSums s;
  for (const LoadRay& r : rays) {
    if (r.side > 0) {
      s.left += r.weight * r.direction;
      s.left_force += r.weight;
      ++s.left_count;
    } else if (r.side < 0) {
      s.right += r.weight * r.direction;
      s.right_force += r.weight;
      ++s.right_count;
    }
  }
  return s;
}

}  // namespace

void finger_load_points(const std::vector<Finger>& fingers, std::vector<LoadPoint>& out) {
  out.clear();
  for (const Finger& f : fingers)
    if (f.vertex >= 0 && !f.released) out.push_back(LoadPoint{f.vertex, f.reaction});
}

void compute_tension_rays(const std::vector<Vec2>& rest, const std::vector<int32_t>& piece, const Topology& topo,
                          int32_t p, std::span<const LoadPoint> loads, const TensionRaysParams& params,
                          TensionRaysScratch& scratch, TensionRays& out) {
  out.valid = false;
  out.status = TensionRaysStatus::NotBoundary;
  out.direction = out.left_direction = out.right_direction = out.bisector = Vec2::Zero();
  out.theta = out.left_force = out.right_force = out.energy_release = 0;
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
    r.direction = path.first_direction;
    if (!path.reachable) ++out.ignored;
  }

  // Eq. 4 in the pattern: b0 the interior bisector at p, then b_i the bisector line of the two sides'
  // mean directions, oriented so each side keeps its label, until the split no longer changes.
  const Vec2& pp = rest[p];
  const double tol = scratch.boundary.tolerance;
  Vec2 b = interior_bisector(topo, rest, p);
  auto split = [&](const Vec2& line) {
    bool changed = false;
    for (int32_t i = 0; i < n; ++i) {
      LoadRay& r = out.rays[i];
      const int32_t side = r.reachable ? path_side(out.paths, out.paths.paths[i], topo, rest, pp, line, tol) : 0;
      changed |= side != r.side;
      r.side = side;
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

  // Eq. 6 and O'Keefe's rule: t = −normalize(u_L + u_R), Er = (F_L + F_R) cos(θ/2) / e.
  const Vec2 ul = s.left.normalized(), ur = s.right.normalized();
  out.left_direction = ul;
  out.right_direction = ur;
  out.theta = std::atan2(std::abs(cross(ul, ur)), ul.dot(ur));
  out.energy_release = (s.left_force + s.right_force) * std::cos(0.5 * out.theta) / params.thickness;
  const Vec2 sum = ul + ur;
  const double sum_norm = sum.norm();
  if (!(sum_norm > params.opposite_tolerance)) {
    out.status = TensionRaysStatus::Opposite;
    return;
  }
  out.direction = -sum / sum_norm;

  // Into the material as in propagation.cpp: strictly between the boundary directions at p.
  const double interior = interior_pattern_angle(topo, rest, p);
  const double at = ccw_angle(rest[topo.boundary_next[p]] - pp, out.direction);
  if (!(at > params.angle_tolerance && at < interior - params.angle_tolerance)) {
    out.status = TensionRaysStatus::NotIntoMaterial;
    return;
  }
  out.valid = true;
  out.status = TensionRaysStatus::Valid;
}

}  // namespace pt
