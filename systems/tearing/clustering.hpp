// Clustering the forces at a potential tearing point (paper §5.1 eq. 4) and mapping the two clusters to
// the pattern (eq. 5); docs/tearing.md "The fan rule".
#pragma once

#include "components/sheet.hpp"

#include <span>

namespace pt {

struct ClusterParams {
  double epsilon = 1e-6;   // stop when ‖b_i − b_{i−1}‖ < ε
  int32_t max_iterations = 20;
};

struct ForceClusters {
  Vec3 left = Vec3::Zero(), right = Vec3::Zero();            // F_left, F_right (3D, N)
  Vec2 left_pattern = Vec2::Zero(), right_pattern = Vec2::Zero();  // F̄_left, F̄_right (pattern)
  Vec3 bisector = Vec3::Zero();                              // final b (unit, tangent plane; see below)
  Vec3 normal = Vec3::Zero();                                // n at p
  int32_t left_count = 0, right_count = 0;
  int32_t iterations = 0;
};

// Conventions: n is the fan's area-weighted normal oriented like the pattern (+z on the flat sheet);
// f_k is in F_left when f_k · (b × n) > 0, in F_right when < 0 (eq. 4). b starts as the interior
// bisector of the boundary tangents, pointing into the sheet, and each iteration takes the bisector line
// of the two clusters, n × normalize(P(F̂_left − F̂_right)) with P the projection on the tangent plane:
// the line of F̂_left + F̂_right for tangent forces, still defined when the clusters are exactly opposite,
// and oriented so the clusters keep their labels. `iterations` counts the b_i computed after b0.
// Forces f_k = corner_force of each triangle around boundary vertex p on p. Needs the boundary
// neighbours of p (topology) for b0. Returns false when p is not a boundary vertex.
bool cluster_tip_forces(const Vertices& verts, const Triangles& tris, const Topology& topo, int32_t p,
                        const ClusterParams& params, ForceClusters& out);

// Σ_k ‖f_k‖ over the fan of p: an upper bound of ‖F_left‖ + ‖F_right‖ whatever the split, so
// Er ≤ fan_force_sum / e (eq. 6, cos(φ/2) ≤ 1). A candidate below Griffith's threshold with this bound
// cannot propagate, and the frame skips its clustering. NaN if a force is not finite.
double fan_force_sum(const Triangles& tris, const Topology& topo, int32_t p);

// The unit normal of a fan of triangles in 3D, area-weighted and oriented like the pattern (triangles are
// counter-clockwise in it); a fan folded flat onto itself has no mean normal and gets its largest
// triangle's, a degenerate one +z.
Vec3 fan_normal(const std::vector<Vec3>& x, const std::vector<Tri>& tri, std::span<const int32_t> fan);

// F⁺ = (FᵀF)⁻¹Fᵀ (2x3) of a 3x2 deformation gradient; zero for a degenerate F.
Eigen::Matrix<double, 2, 3> deformation_pseudo_inverse(const Eigen::Matrix<double, 3, 2>& F);

}  // namespace pt
