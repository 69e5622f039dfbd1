// Energy release rate, Griffith's criterion and the next tip (paper §5.2, eqs. 1, 2, 6).
//
// The two clusters act like O'Keefe's two pulling fingers (paper eq. 2): the tear runs along the
// bisector of their pattern directions, away from them, and releases Er = (‖F_l‖+‖F_r‖) cos(φ/2) / e.
#include "systems/tearing/propagation.hpp"

#include "systems/common/topology.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace pt {
namespace {

// Below this, F̂_l + F̂_r (length 2 cos(φ/2)) has no reliable direction: the pulls are opposite in the
// pattern (φ ≈ π), a flat in-plane pull, which does not tear (docs/tearing.md) and has Er ≈ 0 anyway.
constexpr double kOppositeTolerance = 1e-9;

bool finite(const Vec2& v) { return std::isfinite(v.x()) && std::isfinite(v.y()); }
bool finite(const Vec3& v) { return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z()); }

// Counter-clockwise angle from a to b in [0, 2π).
double ccw_angle(const Vec2& a, const Vec2& b) {
  double angle = std::atan2(a.x() * b.y() - a.y() * b.x(), a.dot(b));
  if (angle < 0) angle += 2 * std::numbers::pi;
  return angle;
}

// t from the unit pre-images: the bisector line of û_l and û_r, pointing away from them. False when it
// has no reliable direction (|û_l + û_r| below kOppositeTolerance).
bool bisector_direction(const Vec2& ul, const Vec2& ur, const PropagationParams& params, Vec2& direction) {
  const Vec2 sum = ul + ur;
  const double sum_norm = sum.norm();
  if (!(sum_norm > kOppositeTolerance)) return false;
  // For unit vectors (û_l + û_r) ⟂ (û_l − û_r), so the bisector line is also the normal of the
  // difference. Near φ = π the sum is a small difference of two noisy vectors (its length is
  // 2 cos(φ/2)) while the difference has length ≈ 2: taking the line from the difference keeps the
  // direction exact as φ → π (the mode-I opening direction); the sum only chooses the sense, and
  // when it is too short to do so reliably, the previous direction of the tear does.
  const Vec2 diff = ul - ur;
  if (sum_norm >= diff.norm()) {
    direction = -sum / sum_norm;  // φ ≤ π/2: the sum is the better conditioned of the two
  } else {
    Vec2 line(-diff.y(), diff.x());
    line.normalize();
    double sense = -line.dot(sum);
    if (sum_norm < params.sense_threshold && params.previous_direction.squaredNorm() > 0)
      sense = line.dot(params.previous_direction);
    direction = sense >= 0 ? line : Vec2(-line);
  }
  return true;
}

}  // namespace

bool direction_into_material(const Topology& topo, const std::vector<Vec2>& rest, int32_t p, const Vec2& t,
                             double tolerance) {
  if (p < 0 || p >= static_cast<int32_t>(topo.boundary_next.size()) || topo.boundary_next[p] < 0) return false;
  const double interior = interior_pattern_angle(topo, rest, p);
  if (!(interior > 0)) return false;
  const double at = ccw_angle(rest[topo.boundary_next[p]] - rest[p], t);
  return at > tolerance && at < interior - tolerance;
}

Vec2 next_tip_position(const Vec2& p, const Vec2& t, double energy_release, const PropagationParams& params) {
  const double step = std::max(std::min(params.speed * energy_release, params.max_step), params.min_step);
  return p + step * t;
}

PropagationDecision decide_propagation(const ForceClusters& clusters, const Topology& topo,
                                       const std::vector<Vec2>& rest, int32_t p, double fracture_energy,
                                       const PropagationParams& params) {
  PropagationDecision d;
  if (p < 0 || p >= static_cast<int32_t>(rest.size()) || p >= static_cast<int32_t>(topo.boundary_next.size()))
    return d;
  const Vec2& fl = clusters.left_pattern;
  const Vec2& fr = clusters.right_pattern;
  const double nl = fl.norm(), nr = fr.norm();
  if (!finite(fl) || !finite(fr) || !finite(clusters.left) || !finite(clusters.right) ||
      !(params.thickness > 0))
    return d;

  // φ ∈ [0, π]: angle between the pattern pre-images F̄_left and F̄_right.
  if (nl > 0 && nr > 0) d.angle = std::atan2(std::abs(fl.x() * fr.y() - fl.y() * fr.x()), fl.dot(fr));

  // Eq. 6 with 3D magnitudes: the pre-images carry the geometry (the angle), the 3D forces the load.
  d.energy_release = (clusters.left.norm() + clusters.right.norm()) * std::cos(0.5 * d.angle) / params.thickness;
  // Griffith (eq. 1): Er ≥ Ef; both virtual fingers must exist. It does not depend on t.
  const bool both = clusters.left_count > 0 && clusters.right_count > 0;
  d.griffith = both && std::isfinite(d.energy_release) && d.energy_release >= fracture_energy;

  // t = −normalize(F̂̄_l + F̂̄_r): internal forces at p point toward the pulling sides, the tear runs
  // the other way along their bisector (Fig. 7); with fixed pulling points A and B this is the tangent of
  // the hyperbola |PA| − |PB| = const (O'Keefe 1994).
  if (!(nl > 0) || !(nr > 0)) return d;
  if (!finite(params.driving_direction)) return d;
  if (params.driving_direction.squaredNorm() > 0) {
    d.direction = params.driving_direction.normalized();
  } else if (!bisector_direction(fl / nl, fr / nr, params, d.direction)) {
    return d;
  }

  // Into the material: t strictly between the boundary directions to next and to prev, measured
  // counter-clockwise from next (the sheet is on the left of prev → p → next), which also covers
  // reflex interior angles (> π) such as a tear tip.
  d.into_material = direction_into_material(topo, rest, p, d.direction, params.angle_tolerance);

  d.propagate = d.griffith && d.into_material;
  if (d.propagate) {
    d.next = next_tip_position(rest[p], d.direction, d.energy_release, params);
    if (!finite(d.next)) {
      d.propagate = false;
      d.next = Vec2::Zero();
    }
  }
  return d;
}

}  // namespace pt
