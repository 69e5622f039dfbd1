// Clustering the membrane forces at a potential tearing point into two virtual fingers (paper §5.1,
// eq. 4) and mapping each cluster to the 2D pattern (paper eq. 5); docs/tearing.md "The fan rule".
//
// Orientation conventions (they make eq. 4 well defined):
//  - n is the area-weighted normal of p's fan, oriented like the pattern (triangles are counter-clockwise
//    in the pattern, so n = +z on the undeformed sheet);
//  - the separating plane through p is spanned by b and n; its normal is m = b × n, and eq. 4 puts f_k in
//    F_left when f_k · m > 0, in F_right when f_k · m < 0 (forces on the plane belong to neither);
//  - b is oriented into the sheet at the start (b0, the interior bisector of the boundary tangents) and
//    by continuity afterwards, see `bisector_from_split`.
#include "systems/tearing/clustering.hpp"

#include "systems/common/topology.hpp"

#include <Eigen/Geometry>
#include <Eigen/LU>

#include <cmath>
#include <numbers>

namespace pt {
namespace {

// Below this length a direction is treated as undefined (unit inputs, so this is relative).
constexpr double kTinyDirection = 1e-12;

Vec3 project_on_plane(const Vec3& v, const Vec3& n) { return v - v.dot(n) * n; }

Vec3 unit_or_zero(const Vec3& v) {
  const double l = v.norm();
  return l > 0 && std::isfinite(l) ? Vec3(v / l) : Vec3::Zero();
}

int32_t corner_of(const Tri& t, int32_t p) {
  for (int32_t i = 0; i < 3; ++i)
    if (t[i] == p) return i;
  return -1;
}

// 3x2 deformation gradient F = [x1 − x0, x2 − x0] · Dm⁻¹ of a constant-strain triangle.
Eigen::Matrix<double, 3, 2> deformation_gradient(const Vertices& verts, const Triangles& tris, int32_t t) {
  const Tri& c = tris.tri[t];
  Eigen::Matrix<double, 3, 2> ds;
  ds.col(0) = verts.x[c[1]] - verts.x[c[0]];
  ds.col(1) = verts.x[c[2]] - verts.x[c[0]];
  return ds * tris.rest_inv[t];
}

// The bisector line of two unit directions u (left) and w (right), in the tangent plane: the plane through
// n perpendicular to P(u − w) separates u and w best (it maximises (u − w)·m over unit m ⊥ n), and for
// tangent vectors it is the line of u + w (they are perpendicular: (u + w)·(u − w) = 0). Taking the line
// from u − w rather than from u + w keeps it defined when the clusters are exactly opposite, which is the
// usual case at a tip close to equilibrium (docs/tearing.md "The fan rule"). Orienting b = n × m̂ keeps the
// labels: u · m > 0 for m = P(u − w) whenever u and w lie in the tangent plane, so the left cluster stays
// left. Returns false when u and w coincide in the tangent plane (no separating plane).
bool bisector_from_split(const Vec3& u, const Vec3& w, const Vec3& n, Vec3& b) {
  const Vec3 m = project_on_plane(u - w, n);
  const double l = m.norm();
  if (!(l > kTinyDirection)) return false;
  b = n.cross(m / l);
  return true;
}

// Eq. 4 for a given b: the sums of the two sides of the plane spanned by b and n.
struct Split {
  Vec3 left = Vec3::Zero(), right = Vec3::Zero();
  int32_t left_count = 0, right_count = 0;
};

Split split_forces(const std::vector<Vec3>& f, const Vec3& b, const Vec3& n) {
  const Vec3 m = b.cross(n);
  Split s;
  for (const Vec3& fk : f) {
    const double side = fk.dot(m);
    if (side > 0) {
      s.left += fk;
      ++s.left_count;
    } else if (side < 0) {
      s.right += fk;
      ++s.right_count;
    }
  }
  return s;
}

}  // namespace

Eigen::Matrix<double, 2, 3> deformation_pseudo_inverse(const Eigen::Matrix<double, 3, 2>& F) {
  // F⁺ = (FᵀF)⁻¹Fᵀ maps a 3D vector of the triangle's tangent plane to its pre-image in the pattern
  // (paper eq. 5: f̄_k = F_k⁺ f_k); components along the triangle's normal are dropped.
  const Mat2 g = F.transpose() * F;
  const double det = g.determinant();
  const double scale = g.trace();
  if (!std::isfinite(det) || !(scale > 0) || !(det > 1e-14 * scale * scale))
    return Eigen::Matrix<double, 2, 3>::Zero();
  return g.inverse() * F.transpose();
}

double fan_force_sum(const Triangles& tris, const Topology& topo, int32_t p) {
  if (p < 0 || p >= topo.vertex_count()) return 0.0;
  double sum = 0;
  for (const int32_t t : topo.fan(p)) {
    const int32_t i = corner_of(tris.tri[t], p);
    if (i >= 0) sum += tris.corner_force[t][i].norm();
  }
  return sum;
}

Vec3 fan_normal(const std::vector<Vec3>& x, const std::vector<Tri>& tri, std::span<const int32_t> fan) {
  Vec3 n = Vec3::Zero();
  Vec3 largest = Vec3::Zero();
  for (const int32_t t : fan) {
    const Tri& c = tri[t];
    const Vec3 area_normal = (x[c[1]] - x[c[0]]).cross(x[c[2]] - x[c[0]]);
    n += area_normal;
    if (area_normal.squaredNorm() > largest.squaredNorm()) largest = area_normal;
  }
  n = unit_or_zero(n.norm() > 1e-6 * largest.norm() ? n : largest);
  return n.isZero() ? Vec3(Vec3::UnitZ()) : n;
}

bool cluster_tip_forces(const Vertices& verts, const Triangles& tris, const Topology& topo, int32_t p,
                        const ClusterParams& params, ForceClusters& out) {
  out = ForceClusters{};
  if (p < 0 || p >= verts.size() || p >= topo.vertex_count()) return false;
  const int32_t next = topo.boundary_next[p], prev = topo.boundary_prev[p];
  if (next < 0 || prev < 0) return false;
  const std::span<const int32_t> fan = topo.fan(p);
  if (fan.empty()) return false;

  // The fan: f_k is the membrane force of triangle k on p (paper §5.1), f̄_k its pattern pre-image
  // (eq. 5). n: area-weighted normal of the fan, oriented like the pattern.
  const int32_t count = static_cast<int32_t>(fan.size());
  std::vector<Vec3> f(count);
  std::vector<Vec2> f_pattern(count);
  for (int32_t k = 0; k < count; ++k) {
    const int32_t t = fan[k];
    const Tri& c = tris.tri[t];
    const int32_t i = corner_of(c, p);
    f[k] = i >= 0 ? tris.corner_force[t][i] : Vec3::Zero();
    f_pattern[k] = deformation_pseudo_inverse(deformation_gradient(verts, tris, t)) * f[k];
  }
  const Vec3 n = fan_normal(verts.x, tris.tri, fan);
  out.normal = n;

  // b0: interior bisector of the boundary tangents at p, in the tangent plane (paper Fig. 6 top). The
  // traversal prev → p → next has the sheet on its left, so n × (t_next − t_prev) is the bisector that
  // points into the sheet for any interior angle: it is t_next + t_prev for a convex corner, −(t_next +
  // t_prev) at a notch (reflex angle), and the inward normal n × t_next on a straight boundary, where
  // t_next + t_prev vanishes.
  const Vec3 t_next = unit_or_zero(verts.x[next] - verts.x[p]);
  const Vec3 t_prev = unit_or_zero(verts.x[prev] - verts.x[p]);
  Vec3 b;
  if (!bisector_from_split(t_next, t_prev, n, b)) {
    // Tangents equal in the tangent plane: a zero-width slit (sheet all around: go against the tangent)
    // or a needle (sheet only along it). The pattern angle tells which.
    const bool reflex = interior_pattern_angle(topo, verts.rest, p) > std::numbers::pi;
    b = unit_or_zero(project_on_plane(t_next, n)) * (reflex ? -1.0 : 1.0);
    if (b.isZero()) return false;
  }

  // Eq. 4, iterated (paper §5.1): b_i is the bisector of F_left^{i−1} and F_right^{i−1}; stop when b
  // moves by less than ε, when a cluster is empty (no bisector) or after max_iterations.
  Split s = split_forces(f, b, n);
  int32_t iterations = 0;
  while (iterations < params.max_iterations && s.left_count > 0 && s.right_count > 0) {
    Vec3 b_next;
    if (!bisector_from_split(unit_or_zero(s.left), unit_or_zero(s.right), n, b_next)) break;
    ++iterations;
    const double moved = (b_next - b).norm();
    b = b_next;
    s = split_forces(f, b, n);
    if (moved < params.epsilon) break;
  }

  // Eq. 5: pattern pre-images summed over the final clusters.
  const Vec3 m = b.cross(n);
  for (int32_t k = 0; k < count; ++k) {
    const double side = f[k].dot(m);
    if (side > 0) out.left_pattern += f_pattern[k];
    else if (side < 0) out.right_pattern += f_pattern[k];
  }
  out.left = s.left;
  out.right = s.right;
  out.left_count = s.left_count;
  out.right_count = s.right_count;
  out.bisector = b;
  out.iterations = iterations;
  return true;
}

}  // namespace pt
