// Clustering of the forces at a tearing point (paper eq. 4) and their pattern pre-images (eq. 5), on
// hand-built fans whose answers are known in closed form (docs/tearing.md "The fan rule").
#include "systems/tearing/clustering.hpp"
#include "systems/common/topology.hpp"

#include <Eigen/Geometry>
#include "tests/test_meshes.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

using namespace pt;

namespace {

constexpr double kPi = std::numbers::pi;

using test::fan_sheet;
using test::flat;
using test::polar;

// Sets the membrane force of triangle t on vertex 0 (its corner 0 in fan_sheet).
void set_force(Sheet& s, int32_t t, const Vec3& f) { s.tris.corner_force[t][0] = f; }

Eigen::Matrix3d rotation(double deg, const Vec3& axis) {
  return Eigen::AngleAxisd(deg * kPi / 180, axis.normalized()).toRotationMatrix();
}

}  // namespace

// Two fingers A and B pull a straight edge: the triangles on A's side of the fan pull p toward A, the
// others toward B (with different magnitudes). The clusters are exactly those two groups, the
// iteration settles at once, b is the bisector of the two pull directions and, the sheet being flat,
// the pattern pre-images equal the forces (F = [I; 0]).
TEST(Clustering, HalfDiscSeparatesTwoFingers) {
  Sheet s = fan_sheet({0, 30, 60, 90, 120, 150, 180});
  ASSERT_EQ(check_mesh_invariants(s), "");
  ASSERT_EQ(s.topo.boundary_next[0], 1);
  ASSERT_EQ(s.topo.boundary_prev[0], 7);
  const Vec2 A(-2, 1), B(3, 0.5);
  const Vec3 ua = flat(A.normalized()), ub = flat(B.normalized());
  const double mag_b[3] = {1, 2, 3}, mag_a[3] = {1.5, 0.5, 2};
  for (int t = 0; t < 3; ++t) set_force(s, t, mag_b[t] * ub);      // right half of the fan (x > 0)
  for (int t = 0; t < 3; ++t) set_force(s, 3 + t, mag_a[t] * ua);  // left half (x < 0)

  ForceClusters c;
  ASSERT_TRUE(cluster_tip_forces(s.verts, s.tris, s.topo, 0, ClusterParams{}, c));
  EXPECT_NEAR((c.normal - Vec3::UnitZ()).norm(), 0, 1e-15);
  // Eq. 4 with b pointing into the sheet: f·(b × n) > 0 is the side of +x, B's side.
  EXPECT_EQ(c.left_count, 3);
  EXPECT_EQ(c.right_count, 3);
  EXPECT_NEAR((c.left - 6.0 * ub).norm(), 0, 1e-14);
  EXPECT_NEAR((c.right - 4.0 * ua).norm(), 0, 1e-14);
  EXPECT_LE(c.iterations, 3);
  const Vec3 bisector = (ua + ub).normalized();
  EXPECT_NEAR((c.bisector - bisector).norm(), 0, 1e-12);
  // Eq. 5 on the undeformed sheet: F⁺ = [I 0], so F̄ = (F.x, F.y).
  EXPECT_NEAR((c.left_pattern - c.left.head<2>()).norm(), 0, 1e-14);
  EXPECT_NEAR((c.right_pattern - c.right.head<2>()).norm(), 0, 1e-14);
}

// The initial plane (b0 = the inward normal of the straight edge) puts a weak force pulling toward 80°
// with the group pulling toward 10–30°; the iterated bisector moves past it and the clusters become
// {10°, 20°, 30°} and {80°, 120°, 140°}, a fixed point of the iteration (its bisector, ~67°, separates them).
TEST(Clustering, IterationReclassifiesWhatTheFirstPlaneGotWrong) {
  Sheet s = fan_sheet({0, 30, 60, 90, 120, 150, 180});
  set_force(s, 0, flat(polar(10)));
  set_force(s, 1, flat(polar(20)));
  set_force(s, 2, flat(polar(30)));
  set_force(s, 3, 0.1 * flat(polar(80)));
  set_force(s, 4, flat(polar(120)));
  set_force(s, 5, flat(polar(140)));
  ForceClusters c;
  ASSERT_TRUE(cluster_tip_forces(s.verts, s.tris, s.topo, 0, ClusterParams{}, c));
  const Vec3 left = flat(polar(10) + polar(20) + polar(30));
  const Vec3 right = flat(0.1 * polar(80) + polar(120) + polar(140));
  EXPECT_EQ(c.left_count, 3);
  EXPECT_EQ(c.right_count, 3);
  EXPECT_NEAR((c.left - left).norm(), 0, 1e-14);
  EXPECT_NEAR((c.right - right).norm(), 0, 1e-14);
  EXPECT_GE(c.iterations, 2);  // it had to move
  EXPECT_LE(c.iterations, 10);
  EXPECT_NEAR((c.bisector - (left.normalized() + right.normalized()).normalized()).norm(), 0, 1e-12);
}

// A tip close to equilibrium: the two clusters are exactly opposite in 3D, F̂_l + F̂_r = 0. The separating
// plane must still be found: b is perpendicular to the line of the forces (docs/tearing.md "The fan rule").
TEST(Clustering, ExactlyOppositeClustersStillSplit) {
  Sheet s = fan_sheet({0, 30, 60, 90, 120, 150, 180});
  const Vec3 d = Vec3(1, 0.3, 0).normalized();
  for (int t = 0; t < 3; ++t) set_force(s, t, (t + 1.0) * d);        // sum 6 d
  for (int t = 0; t < 3; ++t) set_force(s, 3 + t, -2.0 * d);         // sum −6 d
  ForceClusters c;
  ASSERT_TRUE(cluster_tip_forces(s.verts, s.tris, s.topo, 0, ClusterParams{}, c));
  EXPECT_EQ(c.left_count, 3);
  EXPECT_EQ(c.right_count, 3);
  EXPECT_NEAR((c.left - 6 * d).norm(), 0, 1e-14);
  EXPECT_NEAR((c.right + 6 * d).norm(), 0, 1e-14);
  EXPECT_NEAR(c.bisector.norm(), 1, 1e-14);
  EXPECT_NEAR(c.bisector.dot(d), 0, 1e-14);
  EXPECT_NEAR(c.bisector.dot(Vec3::UnitZ()), 0, 1e-14);
  EXPECT_GT(c.bisector.y(), 0);  // still oriented into the sheet, as b0
}

// A rigid motion of the whole fan and its forces rotates the 3D results and leaves the clusters and the
// pattern pre-images unchanged (eq. 5 undoes the rotation).
TEST(Clustering, RigidMotionLeavesPatternPreImagesUnchanged) {
  Sheet s = fan_sheet({-20, 20, 70, 110, 160, 200});
  const Vec2 A(-1, 2), B(1.5, 1.8);
  for (int t = 0; t < 5; ++t) {
    const Vec2 target = t < 2 ? B : A;
    set_force(s, t, (0.5 + t) * flat(target.normalized()));
  }
  ForceClusters ref;
  ASSERT_TRUE(cluster_tip_forces(s.verts, s.tris, s.topo, 0, ClusterParams{}, ref));
  ASSERT_EQ(ref.left_count + ref.right_count, 5);
  ASSERT_GT(ref.left_count, 0);
  ASSERT_GT(ref.right_count, 0);

  const Eigen::Matrix3d R = rotation(73, Vec3(0.3, -1, 0.6));
  const Vec3 shift(0.2, -0.1, 0.7);
  Sheet moved = s;
  for (Vec3& x : moved.verts.x) x = R * x + shift;
  for (auto& fc : moved.tris.corner_force)
    for (Vec3& f : fc) f = R * f;
  ForceClusters c;
  ASSERT_TRUE(cluster_tip_forces(moved.verts, moved.tris, moved.topo, 0, ClusterParams{}, c));
  EXPECT_EQ(c.left_count, ref.left_count);
  EXPECT_EQ(c.right_count, ref.right_count);
  EXPECT_NEAR((c.normal - R * Vec3::UnitZ()).norm(), 0, 1e-12);
  EXPECT_NEAR((c.left - R * ref.left).norm(), 0, 1e-12);
  EXPECT_NEAR((c.right - R * ref.right).norm(), 0, 1e-12);
  EXPECT_NEAR((c.bisector - R * ref.bisector).norm(), 0, 1e-12);
  EXPECT_NEAR((c.left_pattern - ref.left_pattern).norm(), 0, 1e-12);
  EXPECT_NEAR((c.right_pattern - ref.right_pattern).norm(), 0, 1e-12);
}

// Trouser-like pull at a notch tip: the two lips are folded out of the sheet, one up and one down (the
// legs of a trouser test), so the same fan holds three different deformation gradients. The lips pull p
// with 3D forces that are exactly opposite (nearly ±z), yet their pre-images both point back along the
// tear toward the lips: φ is small (docs/tearing.md "The fan rule").
TEST(Clustering, TrouserLipsMapBackTowardTheLips) {
  Sheet s = fan_sheet({100, 140, 180, 225, 270, 315, 360, 400, 440});
  ASSERT_EQ(check_mesh_invariants(s), "");
  ASSERT_TRUE(s.verts.flags[0] & kInward);
  for (int32_t v = 0; v < s.verts.size(); ++v) {
    const Vec2 r = s.verts.rest[v];
    s.verts.x[v] = r.y() <= 0 ? flat(r) : r.x() < 0 ? Vec3(r.x(), 0, r.y()) : Vec3(r.x(), 0, -r.y());
  }
  const double beta = 10 * kPi / 180;
  const Vec3 up(-std::sin(beta), 0, std::cos(beta)), down(std::sin(beta), 0, -std::cos(beta));
  set_force(s, 0, 0.5 * up);    // left lip: triangles 0, 1 (pattern x < 0, y > 0)
  set_force(s, 1, 0.5 * up);
  set_force(s, 6, 0.5 * down);  // right lip: triangles 6, 7
  set_force(s, 7, 0.5 * down);
  ForceClusters c;
  ASSERT_TRUE(cluster_tip_forces(s.verts, s.tris, s.topo, 0, ClusterParams{}, c));
  EXPECT_NEAR((c.normal - Vec3::UnitZ()).norm(), 0, 1e-12);
  EXPECT_EQ(c.left_count, 2);
  EXPECT_EQ(c.right_count, 2);
  EXPECT_NEAR((c.left - up).norm(), 0, 1e-14);
  EXPECT_NEAR((c.right - down).norm(), 0, 1e-14);
  EXPECT_NEAR(c.left.normalized().dot(c.right.normalized()), -1, 1e-14);  // opposite in 3D
  // Pre-images: F_left = [e_x e_z], F_right = [e_x −e_z] ⇒ (∓sin β, cos β).
  EXPECT_NEAR((c.left_pattern - Vec2(-std::sin(beta), std::cos(beta))).norm(), 0, 1e-12);
  EXPECT_NEAR((c.right_pattern - Vec2(std::sin(beta), std::cos(beta))).norm(), 0, 1e-12);
  const double phi = std::acos(c.left_pattern.normalized().dot(c.right_pattern.normalized()));
  EXPECT_NEAR(phi, 2 * beta, 1e-9);
}

TEST(Clustering, InteriorVertexIsRejected) {
  Sheet s = fan_sheet({0, 90, 180, 270});
  s.tris.resize(4);
  s.tris.tri[3] = Tri{0, 4, 1};  // close the fan
  refresh_after_topology_change(s);
  ASSERT_EQ(s.topo.boundary_next[0], -1);
  ForceClusters c;
  EXPECT_FALSE(cluster_tip_forces(s.verts, s.tris, s.topo, 0, ClusterParams{}, c));
  EXPECT_FALSE(cluster_tip_forces(s.verts, s.tris, s.topo, -1, ClusterParams{}, c));
  EXPECT_FALSE(cluster_tip_forces(s.verts, s.tris, s.topo, 99, ClusterParams{}, c));
}

// All forces on one side: one cluster is empty, the iteration stops and says so.
TEST(Clustering, OneSidedForcesLeaveAClusterEmpty) {
  Sheet s = fan_sheet({0, 60, 120, 180});
  for (int t = 0; t < 3; ++t) set_force(s, t, flat(polar(20 + 10 * t)));
  ForceClusters c;
  ASSERT_TRUE(cluster_tip_forces(s.verts, s.tris, s.topo, 0, ClusterParams{}, c));
  EXPECT_EQ(c.left_count, 3);
  EXPECT_EQ(c.right_count, 0);
  EXPECT_EQ(c.iterations, 0);
  EXPECT_NEAR((c.bisector - Vec3::UnitY()).norm(), 0, 1e-15);  // b0: inward normal of the straight edge
}

// b0 is the interior bisector of the boundary tangents at a convex corner and at a notch.
TEST(Clustering, InitialBisectorPointsIntoTheSheet) {
  for (const auto& ring : std::vector<std::vector<double>>{{10, 50, 90}, {100, 180, 270, 360, 440}}) {
    Sheet s = fan_sheet(ring);
    const double mid = 0.5 * (ring.front() + ring.back());
    ForceClusters c;
    ASSERT_TRUE(cluster_tip_forces(s.verts, s.tris, s.topo, 0, ClusterParams{}, c));  // no forces: b = b0
    EXPECT_EQ(c.iterations, 0);
    EXPECT_NEAR((c.bisector - flat(polar(mid))).norm(), 0, 1e-12) << mid;
  }
}

// F⁺ = (FᵀF)⁻¹Fᵀ: identity on the flat sheet, the pre-image under a rigid rotation, a left inverse of
// a stretched and rotated F, and zero for a degenerate one.
TEST(Clustering, DeformationPseudoInverse) {
  Eigen::Matrix<double, 3, 2> F0 = Eigen::Matrix<double, 3, 2>::Zero();
  F0(0, 0) = F0(1, 1) = 1;
  const Eigen::Matrix<double, 2, 3> P0 = deformation_pseudo_inverse(F0);
  const Vec3 f(0.3, -1.2, 0.7);
  EXPECT_NEAR((P0 * f - Vec2(0.3, -1.2)).norm(), 0, 1e-15);

  const Eigen::Matrix3d R = rotation(117, Vec3(1, 2, -0.5));
  const Eigen::Matrix<double, 3, 2> F = R * F0;
  const Eigen::Matrix<double, 2, 3> P = deformation_pseudo_inverse(F);
  const Vec2 g(-0.4, 2.5);
  EXPECT_NEAR((P * (R * flat(g)) - g).norm(), 0, 1e-14);
  EXPECT_NEAR((P * (R * Vec3::UnitZ())).norm(), 0, 1e-14);  // the normal has no pre-image

  Mat2 S;
  S << 1.01, 0.003, 0.003, 0.995;
  const Eigen::Matrix<double, 3, 2> Fs = R * F0 * S;
  EXPECT_NEAR((deformation_pseudo_inverse(Fs) * Fs - Mat2::Identity()).norm(), 0, 1e-13);

  Eigen::Matrix<double, 3, 2> rank1;
  rank1.col(0) = Vec3(1, 2, 3);
  rank1.col(1) = 2 * Vec3(1, 2, 3);
  EXPECT_TRUE(deformation_pseudo_inverse(rank1).isZero());
  EXPECT_TRUE(deformation_pseudo_inverse(Eigen::Matrix<double, 3, 2>::Zero()).isZero());
}
