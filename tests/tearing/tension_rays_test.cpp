// Tension rays (systems/tearing/tension_rays.hpp): the tear direction from the load points' shortest
// paths, checked against O'Keefe's analysis of two fingers (the hyperbola |PA| − |PB| = const), paths
// around slits computed by hand, and the same outline on different meshes.
#include "systems/tearing/tension_rays.hpp"
#include "systems/mesh/meshing.hpp"
#include "systems/mesh/remeshing.hpp"
#include "systems/common/topology.hpp"

#include "tests/test_meshes.hpp"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>

using namespace pt;
using test::Slit;
using test::slit_grid;
using test::vertex_at;

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kW = 0.2, kH = 0.15;
constexpr double kThickness = 1e-4;

TensionRaysParams params() {
  TensionRaysParams p;
  p.thickness = kThickness;
  return p;
}

struct Load {
  Vec2 at;
  double force;
  Vec2 side = Vec2::Zero();  // which copy when `at` is on a lip
};

TensionRays rays_at(const Sheet& s, int32_t p, const std::vector<Load>& loads,
                    const Vec2& previous_direction = Vec2::Zero(), TensionRaysParams rp = params()) {
  // Loads left of p (by x, or by the lip they hold) pull up and the others down, as a trouser's legs: the
  // sides' summed reactions then differ by F_L + F_R.
  std::vector<LoadPoint> points;
  for (const Load& l : loads) {
    const int32_t v = vertex_at(s, l.at, l.side);
    EXPECT_GE(v, 0) << l.at.transpose();
    const double dx = l.side.x() != 0 ? l.side.x() : l.at.x() - s.verts.rest[p].x();
    points.push_back(LoadPoint{v, Vec3(0, 0, dx < 0 ? l.force : -l.force)});
  }
  TensionRaysScratch scratch;
  TensionRays out;
  rp.previous_direction = previous_direction;
  compute_tension_rays(s.verts.rest, s.tris.piece, s.topo, p, points, rp, scratch, out);
  return out;
}

// The rays at p for two loads, at A (pulled by `left_pull`) and B, with the sheet's normal.
TensionRays two_pulls(const Sheet& s, int32_t p, const Vec2& A, const Vec3& left_pull, const Vec2& B, const Vec3& right_pull,
                      const Vec3& normal) {
  const std::vector<LoadPoint> loads = {{vertex_at(s, A), left_pull}, {vertex_at(s, B), right_pull}};
  TensionRaysParams rp = params();
  rp.normal = normal;
  TensionRaysScratch scratch;
  TensionRays out;
  compute_tension_rays(s.verts.rest, s.tris.piece, s.topo, p, loads, rp, scratch, out);
  return out;
}

// The tangent at P of the hyperbola |PA| − |PB| = const, away from the foci: orthogonal to the gradient
// of |PA| − |PB|, which is unit(P − A) − unit(P − B).
Vec2 hyperbola_tangent(const Vec2& P, const Vec2& A, const Vec2& B) {
  const Vec2 grad = (P - A).normalized() - (P - B).normalized();
  Vec2 t = Vec2(-grad.y(), grad.x()).normalized();
  if (t.dot((A - P) + (B - P)) > 0) t = -t;
  return t;
}

// Angle APB from the side lengths (law of cosines).
double angle_at(const Vec2& P, const Vec2& A, const Vec2& B) {
  const double a = (A - P).norm(), b = (B - P).norm(), c = (A - B).norm();
  return std::acos((a * a + b * b - c * c) / (2 * a * b));
}

Sheet one_slit() { return slit_grid(kW, kH, 20, 15, {Slit{10, 6}}); }
const Vec2 kSlitTip(0.1, 0.06);

// The sheet the mesher makes of `req`; `held` gets the vertex of each required point.
Sheet meshed(const MeshRequest& req, std::vector<int32_t>& held) {
  Sheet s;
  mesh_outline(req, s.verts.rest, s.tris.tri, held);
  s.verts.resize(static_cast<int32_t>(s.verts.rest.size()));
  s.tris.resize(static_cast<int32_t>(s.tris.tri.size()));
  refresh_after_topology_change(s);
  return s;
}

// The same for `outline` with a vertex at each required point.
Sheet meshed(const std::vector<Vec2>& outline, const std::vector<Vec2>& required, int32_t triangles) {
  MeshRequest req;
  req.outline = outline;
  req.required_points = required;
  req.target_triangles = triangles;
  std::vector<int32_t> held;
  return meshed(req, held);
}

}  // namespace

// O'Keefe: on an unslit sheet t is along the hyperbola's tangent at p and θ the angle APB. At p on the
// straight bottom edge the tangent away from the foci points out of the sheet, so the start runs along
// the same line towards them.
TEST(TensionRays, TwoFingersFollowTheHyperbolaOnAnUnslitSheet) {
  const Sheet s = slit_grid(kW, kH, 20, 15, {});
  const Vec2 P(0.1, 0.0), A(0.05, 0.1), B(0.17, 0.08);
  const TensionRays r = rays_at(s, vertex_at(s, P), {{A, 0.8}, {B, 0.5}});
  ASSERT_EQ(r.rays.size(), 2u);
  EXPECT_TRUE(r.rays[0].straight && r.rays[1].straight);
  EXPECT_EQ(r.left_count, 1);
  EXPECT_EQ(r.right_count, 1);
  EXPECT_NEAR((r.direction + hyperbola_tangent(P, A, B)).norm(), 0, 1e-9);
  EXPECT_NEAR(r.theta, angle_at(P, A, B), 1e-9);
  // Moving along t keeps |PA| − |PB| constant to first order.
  const double h = 1e-5;
  auto f = [&](const Vec2& X) { return (X - A).norm() - (X - B).norm(); };
  EXPECT_LT(std::abs(f(P + h * r.direction) - f(P)), 1e-2 * h);
  EXPECT_GT(r.direction.y(), 0);
  EXPECT_TRUE(r.valid) << int(r.status);
}

// A tip whose fingers lie ahead of it (the tear is about to pass between them) keeps running the way it
// runs: t along the hyperbola's tangent, oriented by the last segment, not turned back into its lips.
TEST(TensionRays, ATipKeepsItsWayAlongTheTangent) {
  const Sheet s = one_slit();
  const Vec2 A(0.05, 0.08), B(0.16, 0.1);
  const TensionRays away = rays_at(s, vertex_at(s, kSlitTip), {{A, 0.8}, {B, 0.5}});
  const TensionRays kept = rays_at(s, vertex_at(s, kSlitTip), {{A, 0.8}, {B, 0.5}}, Vec2(0, 1));
  ASSERT_TRUE(away.valid && kept.valid);
  EXPECT_NEAR((away.direction - hyperbola_tangent(kSlitTip, A, B)).norm(), 0, 1e-9);
  EXPECT_LT(away.direction.y(), 0);  // folds back beside the lips without the tip's direction
  EXPECT_NEAR((kept.direction + hyperbola_tangent(kSlitTip, A, B)).norm(), 0, 1e-9);
  EXPECT_GT(kept.direction.y(), 0);
  EXPECT_DOUBLE_EQ(kept.energy_release, away.energy_release);
}

// The same at a slit's tip, where the tangent does point into the sheet: valid, Er from eq. 6.
TEST(TensionRays, TwoFingersFollowTheHyperbolaAtASlitTip) {
  const Sheet s = one_slit();
  const Vec2 A(0.05, 0.02), B(0.16, 0.03);
  const TensionRays r = rays_at(s, vertex_at(s, kSlitTip), {{A, 0.8}, {B, 0.5}});
  ASSERT_TRUE(r.valid) << int(r.status);
  EXPECT_TRUE(r.rays[0].straight && r.rays[1].straight);
  EXPECT_NEAR((r.direction - hyperbola_tangent(kSlitTip, A, B)).norm(), 0, 1e-9);
  const double theta = angle_at(kSlitTip, A, B);
  EXPECT_NEAR(r.theta, theta, 1e-9);
  EXPECT_NEAR(r.energy_release, 1.3 * std::cos(theta / 2) / kThickness, 1e-9 * 1.3 / kThickness);
  EXPECT_DOUBLE_EQ(r.left_force + r.right_force, 1.3);
}

// Symmetric fingers: t along the mediator of AB through p, whatever the forces.
TEST(TensionRays, SymmetricFingersTearAlongTheMediator) {
  const Sheet s = one_slit();
  for (double fb : {0.5, 2.0}) {
    const TensionRays r = rays_at(s, vertex_at(s, kSlitTip), {{Vec2(0.04, 0.02), 0.5}, {Vec2(0.16, 0.02), fb}});
    ASSERT_TRUE(r.valid);
    EXPECT_NEAR((r.direction - Vec2(0, 1)).norm(), 0, 1e-12);
  }
}

// Two slits: from the first tip p the straight line to B crosses the second slit, so B pulls p toward
// the second tip T2 (the corner the shortest path bends around), not toward B.
TEST(TensionRays, PathBendsAroundTheSlitEnd) {
  const Sheet s = slit_grid(kW, kH, 20, 15, {Slit{6, 5}, Slit{12, 8}});
  const Vec2 P(0.06, 0.05), T2(0.12, 0.08), A(0.03, 0.02), B(0.16, 0.03);
  const TensionRays r = rays_at(s, vertex_at(s, P), {{A, 0.7}, {B, 0.9}});
  ASSERT_EQ(r.rays.size(), 2u);
  EXPECT_TRUE(r.rays[0].straight);
  EXPECT_FALSE(r.rays[1].straight);
  EXPECT_EQ(r.rays[1].first_corner, vertex_at(s, T2));
  const Vec2 gb(0.06, 0.03);  // T2 − P by hand
  EXPECT_NEAR((r.rays[1].direction - gb / std::sqrt(0.0045)).norm(), 0, 1e-12);
  EXPECT_GT((r.rays[1].direction - (B - P).normalized()).norm(), 0.1);
  EXPECT_NEAR(r.rays[1].path_length, (T2 - P).norm() + (B - T2).norm(), 1e-12);
  const Vec2 ga = (A - P).normalized();
  const Vec2 t = -(ga + gb.normalized()).normalized();
  ASSERT_TRUE(r.valid);
  EXPECT_NEAR((r.direction - t).norm(), 0, 1e-12);
  // t is the hyperbola tangent with the second focus moved to the corner (O'Keefe around the obstacle).
  EXPECT_NEAR((r.direction - hyperbola_tangent(P, A, T2)).norm(), 0, 1e-9);
}

// A notch in the outline (no tear): the path bends at the notch's inner corner.
TEST(TensionRays, PathBendsAroundANotchCorner) {
  // A slot 0.12 ≤ x ≤ 0.13 from the bottom up to y = 0.10; p at the tip of a V notch in the top edge.
  const std::vector<Vec2> outline{{0, 0},     {0.12, 0},   {0.12, 0.10}, {0.13, 0.10}, {0.13, 0},
                                  {0.2, 0},   {0.2, 0.15}, {0.07, 0.15}, {0.06, 0.08}, {0.05, 0.15},
                                  {0, 0.15}};
  const Vec2 P(0.06, 0.08), C(0.12, 0.10), A(0.02, 0.03), B(0.17, 0.03);
  const Sheet s = meshed(outline, {A, B}, 300);
  const TensionRays r = rays_at(s, vertex_at(s, P), {{A, 1.0}, {B, 1.0}});
  ASSERT_EQ(r.rays.size(), 2u);
  EXPECT_TRUE(r.rays[0].straight);
  EXPECT_FALSE(r.rays[1].straight);
  EXPECT_EQ(r.rays[1].first_corner, vertex_at(s, C));
  EXPECT_NEAR((r.rays[1].direction - (C - P).normalized()).norm(), 0, 1e-12);
  const Vec2 C2(0.13, 0.10);
  EXPECT_NEAR(r.rays[1].path_length, (C - P).norm() + 0.01 + (B - C2).norm(), 1e-12);
  ASSERT_TRUE(r.valid);
  EXPECT_NEAR((r.direction - hyperbola_tangent(P, A, C)).norm(), 0, 1e-9);
}

// A trouser's slit cut 1 mm wide (a blunt end with two corners): from the end's left corner the path to
// the right leg's finger first runs 1 mm along the end, across the tear's line. Its bearing skips that
// corner (closer than bearing_length), so θ is the angle between the legs' fingers seen from the end and
// the tear runs straight down the slit's line; read from the first segment (bearing_length 0) θ would be
// ~100° and Er 35% short. A slot as wide as the bearing length keeps its corner: a real feature.
TEST(TensionRays, ABluntSlitEndDoesNotSteerTheTear) {
  auto trouser = [](double width) {
    const double l = 0.02 - 0.5 * width, r = 0.02 + 0.5 * width;
    return meshed({{0, 0}, {0.04, 0}, {0.04, 0.12}, {r, 0.12}, {r, 0.06}, {l, 0.06}, {l, 0.12}, {0, 0.12}},
                  {{0.01, 0.115}, {0.03, 0.115}}, 300);
  };
  const Vec2 A(0.01, 0.115), B(0.03, 0.115);
  {
    const Sheet s = trouser(0.001);
    const Vec2 P(0.0195, 0.06);
    const TensionRays r = rays_at(s, vertex_at(s, P), {{A, 1.0}, {B, 1.0}});
    ASSERT_EQ(r.rays.size(), 2u);
    EXPECT_NEAR((r.rays[1].direction - Vec2(1, 0)).norm(), 0, 1e-9);  // along the slit's end
    EXPECT_NEAR((r.rays[1].bearing - (B - P).normalized()).norm(), 0, 1e-9);
    ASSERT_TRUE(r.valid);
    EXPECT_NEAR(r.theta, angle_at(P, A, B), 1e-9);
    EXPECT_NEAR((r.direction + ((A - P).normalized() + (B - P).normalized()).normalized()).norm(), 0, 1e-9);
    EXPECT_LT(r.direction.y(), -0.99);
    EXPECT_NEAR(r.energy_release, 2.0 * std::cos(0.5 * angle_at(P, A, B)) / kThickness, 1e-6);

    TensionRaysScratch scratch;
    TensionRays first_segment;
    TensionRaysParams rp = params();
    rp.bearing_length = 0;
    std::vector<LoadPoint> loads{{vertex_at(s, A), Vec3(0, 0, 1)}, {vertex_at(s, B), Vec3(0, 0, -1)}};
    compute_tension_rays(s.verts.rest, s.tris.piece, s.topo, vertex_at(s, P), loads, rp, scratch, first_segment);
    EXPECT_GT(first_segment.theta, 1.5);
  }
  {
    const Sheet s = trouser(0.01);
    const Vec2 P(0.015, 0.06), C(0.025, 0.06);
    const TensionRays r = rays_at(s, vertex_at(s, P), {{A, 1.0}, {B, 1.0}});
    ASSERT_EQ(r.rays.size(), 2u);
    EXPECT_EQ(r.rays[1].first_corner, vertex_at(s, C));
    EXPECT_NEAR((r.rays[1].bearing - Vec2(1, 0)).norm(), 0, 1e-9);
  }
}

// A tear cut by the remesher (systems/mesh/remeshing.hpp): up from the bottom edge along grid vertices, then
// turning 45° right across the cells' diagonals (split at their middles, so the lips stay straight: on
// a jittered grid the remesher snaps the cut to nearby vertices and the lips zigzag, which moves the
// corners). A finger on the left pulls the tip around the kink, a reflex corner of the left lip; one
// on the right sees the tip directly.
TEST(TensionRays, PathBendsAtTheKinkOfACutTear) {
  Sheet s = test::alternating_grid(kW, kH, 16, 12, 0.0, 1);
  const int32_t start = vertex_at(s, Vec2(0.1, 0.0));
  const CutResult c1 = cut_tear_segment(start, Vec2(0.1, 0.0625), Vec2::Zero(), 0, RemeshParams{}, s);
  ASSERT_TRUE(c1.cut && c1.tip_vertex >= 0);
  const Vec2 kink = c1.end;
  EXPECT_NEAR((kink - Vec2(0.1, 0.0625)).norm(), 0, 1e-15);
  const CutResult c2 =
      cut_tear_segment(c1.tip_vertex, kink + Vec2(0.0375, 0.0375), Vec2(0, 1), 0, RemeshParams{}, s);
  ASSERT_TRUE(c2.cut && c2.tip_vertex >= 0);
  ASSERT_EQ(check_mesh_invariants(s), "");
  const Vec2 tip = c2.end, A(0.05, 0.0), B(0.15, 0.0);
  const TensionRays r = rays_at(s, c2.tip_vertex, {{A, 0.5}, {B, 0.5}});
  ASSERT_EQ(r.rays.size(), 2u);
  EXPECT_FALSE(r.rays[0].straight);
  ASSERT_GE(r.rays[0].first_corner, 0);
  EXPECT_NEAR((s.verts.rest[r.rays[0].first_corner] - kink).norm(), 0, 1e-15);
  EXPECT_NEAR((r.rays[0].direction - (kink - tip).normalized()).norm(), 0, 1e-12);
  EXPECT_NEAR(r.rays[0].path_length, (kink - tip).norm() + (A - kink).norm(), 1e-12);
  EXPECT_TRUE(r.rays[1].straight);
  // A's path leaves along the left lip, straight behind b0: it is on the left although A itself lies
  // right of b0's line (the tear bends).
  EXPECT_EQ(r.rays[0].side, 1);
  EXPECT_EQ(r.rays[1].side, -1);
  ASSERT_TRUE(r.valid) << int(r.status);
  EXPECT_NEAR((r.direction - hyperbola_tangent(tip, kink, B)).norm(), 0, 1e-9);
}

// Only load points on p's piece count: a finger on the far side of a full cut is ignored.
TEST(TensionRays, FingerOnAnotherPieceIsIgnored) {
  const Sheet s = slit_grid(kW, kH, 20, 15, {Slit{5, 6}, Slit{10, 15}});
  ASSERT_EQ(s.topo.piece_count, 2);
  const int32_t p = vertex_at(s, Vec2(0.05, 0.06));
  const Load a{Vec2(0.02, 0.02), 0.6}, b{Vec2(0.08, 0.01), 0.4}, c{Vec2(0.15, 0.03), 5.0};
  const TensionRays with = rays_at(s, p, {a, b, c});
  const TensionRays without = rays_at(s, p, {a, b});
  EXPECT_EQ(with.other_piece, 1);
  ASSERT_EQ(with.rays.size(), 2u);
  ASSERT_TRUE(with.valid);
  EXPECT_EQ(with.direction, without.direction);
  EXPECT_EQ(with.energy_release, without.energy_release);
  // With the other finger alone beside one of p's piece: one side is empty.
  const TensionRays lonely = rays_at(s, p, {a, c});
  EXPECT_FALSE(lonely.valid);
  EXPECT_EQ(lonely.status, TensionRaysStatus::EmptySide);
}

TEST(TensionRays, AnEmptySideIsInvalid) {
  const Sheet s = one_slit();
  const int32_t p = vertex_at(s, kSlitTip);
  const TensionRays one = rays_at(s, p, {{Vec2(0.05, 0.02), 1.0}});
  EXPECT_FALSE(one.valid);
  EXPECT_EQ(one.status, TensionRaysStatus::EmptySide);
  // Two fingers on one ray from p pull the same way: no line separates them.
  const TensionRays same = rays_at(s, p, {{Vec2(0.08, 0.04), 1.0}, {Vec2(0.04, 0.0), 1.0}});
  EXPECT_FALSE(same.valid);
  EXPECT_EQ(same.status, TensionRaysStatus::EmptySide);
  EXPECT_EQ(same.left_count + same.right_count, 2);
}

// Trouser tear: fingers on the two lips at the slit's mouth pull straight back, θ = 0 and Er = (F_L + F_R)/e;
// their paths run along the slit, each on its own lip.
TEST(TensionRays, FingersDirectlyBehindReleaseEverything) {
  const Sheet s = one_slit();
  const int32_t p = vertex_at(s, kSlitTip);
  const TensionRays r = rays_at(s, p, {{Vec2(0.1, 0.0), 0.7, Vec2(-1, 1)}, {Vec2(0.1, 0.0), 0.4, Vec2(1, 1)}});
  ASSERT_TRUE(r.valid) << int(r.status);
  EXPECT_EQ(r.left_count, 1);
  EXPECT_EQ(r.right_count, 1);
  EXPECT_TRUE(r.rays[0].straight && r.rays[1].straight);
  EXPECT_EQ(r.theta, 0.0);
  EXPECT_NEAR((r.direction - Vec2(0, 1)).norm(), 0, 1e-15);
  EXPECT_NEAR(r.energy_release, 1.1 / kThickness, 1e-12 / kThickness);
  // The left lip's finger is on the left of b = +y.
  EXPECT_EQ(r.rays[0].side, 1);
  EXPECT_EQ(r.rays[1].side, -1);
}

// Er's two parts (tension_rays.cpp): with the sheet's normal given, the opening force across the sheet
// (a hand lifting one side, a trouser's legs) releases F_L + F_R whatever the bearings; in the plane
// O'Keefe's cos(θ/2) still weighs it; without a normal every pull is read as in the plane.
TEST(TensionRays, PullsAcrossTheSheetReleaseAsATrousersLegs) {
  const Sheet s = one_slit();
  const int32_t p = vertex_at(s, kSlitTip);
  const Vec2 A(0.05, 0.03), B(0.15, 0.03);
  const double theta = angle_at(kSlitTip, A, B);  // 2 atan(5/3) ≈ 118°
  auto er = [&](const Vec3& left_pull, const Vec3& right_pull, const Vec3& normal) {
    const TensionRays out = two_pulls(s, p, A, left_pull, B, right_pull, normal);
    EXPECT_TRUE(out.valid) << int(out.status);
    EXPECT_NEAR(out.theta, theta, 1e-12);
    return out.energy_release * kThickness;  // N
  };
  const Vec3 up(0, 0, 1), none = Vec3::Zero();
  EXPECT_NEAR(er(0.7 * up, -0.4 * up, none), 1.1 * std::cos(theta / 2), 1e-12);
  EXPECT_NEAR(er(0.7 * up, -0.4 * up, up), 1.1, 1e-12);
  EXPECT_NEAR(er(0.7 * up, -0.4 * up, -up), 1.1, 1e-12);  // the normal's sense does not matter
  // Pulls along their bearings, in the plane: the same with or without the normal.
  const Vec3 a = Vec3(A.x() - kSlitTip.x(), A.y() - kSlitTip.y(), 0).normalized();
  const Vec3 b = Vec3(B.x() - kSlitTip.x(), B.y() - kSlitTip.y(), 0).normalized();
  EXPECT_NEAR(er(0.7 * a, 0.4 * b, up), er(0.7 * a, 0.4 * b, none), 1e-12);
  EXPECT_NEAR(er(0.7 * a, 0.4 * b, up), (0.7 * a - 0.4 * b).norm() * std::cos(theta / 2), 1e-12);
  // Both: the parts add as orthogonal vectors.
  EXPECT_NEAR(er(0.7 * a + 0.3 * up, 0.4 * b - 0.2 * up, up),
              std::hypot(0.5, (0.7 * a - 0.4 * b).norm() * std::cos(theta / 2)), 1e-12);
}

// sensed_energy_release: of the in-plane part of P_L − P_R only a pull apart counts, not a push together;
// the part along the tear's line (a shear) and the part across the sheet count whatever their sense.
TEST(TensionRays, OnlyAPullApartOpensInThePlane) {
  const Sheet s = one_slit();
  const int32_t p = vertex_at(s, kSlitTip);
  const Vec2 A(0.05, 0.03), B(0.15, 0.03);
  const Vec3 a = Vec3(A.x() - kSlitTip.x(), A.y() - kSlitTip.y(), 0).normalized();
  const Vec3 b = Vec3(B.x() - kSlitTip.x(), B.y() - kSlitTip.y(), 0).normalized();
  const Vec3 up(0, 0, 1);
  auto rays = [&](const Vec3& left_pull, const Vec3& right_pull) { return two_pulls(s, p, A, left_pull, B, right_pull, up); };
  const TensionRays pull = rays(0.7 * a, 0.4 * b);
  ASSERT_TRUE(pull.valid);
  const Vec2 left2(-pull.bisector.y(), pull.bisector.x());
  ASSERT_GT(left2.dot(A - kSlitTip), 0) << "A's side is the left";
  const Vec3 left(left2.x(), left2.y(), 0), along(pull.bisector.x(), pull.bisector.y(), 0);
  const double c = std::cos(pull.theta / 2);
  // Pulled apart: as compute_tension_rays reads it.
  EXPECT_NEAR(sensed_energy_release(pull, up, left, kThickness), pull.energy_release, 1e-9);
  EXPECT_NEAR(sensed_energy_release(pull, up, left, kThickness) * kThickness, (0.7 * a - 0.4 * b).norm() * c, 1e-12);
  // Pushed together by the same forces: only their part along the line is left.
  const TensionRays push = rays(-0.7 * a, -0.4 * b);
  EXPECT_NEAR(push.energy_release, pull.energy_release, 1e-9) << "without the sense they read the same";
  EXPECT_NEAR(sensed_energy_release(push, up, left, kThickness) * kThickness,
              std::abs((0.7 * a - 0.4 * b).dot(along)) * c, 1e-12);
  // Across the sheet, whatever the in-plane sense: the parts add as orthogonal vectors.
  const TensionRays lift = rays(-0.7 * a + 0.3 * up, -0.4 * b - 0.2 * up);
  EXPECT_NEAR(sensed_energy_release(lift, up, left, kThickness) * kThickness,
              std::hypot(0.5, (0.7 * a - 0.4 * b).dot(along) * c), 1e-12);
  // No sense given (zero, or along the normal): compute_tension_rays' Er.
  EXPECT_EQ(sensed_energy_release(push, up, Vec3::Zero(), kThickness), push.energy_release);
  EXPECT_EQ(sensed_energy_release(push, up, up, kThickness), push.energy_release);
}

// θ = π: opposite in-plane pulls give no direction, and release only the opening floor's share of their
// pull (mode I), not nothing; with the floor at 0, nothing (O'Keefe's cos(θ/2) alone).
TEST(TensionRays, OppositePullsReleaseOnlyTheOpeningFloor) {
  const Sheet s = one_slit();
  const TensionRays r = rays_at(s, vertex_at(s, kSlitTip), {{Vec2(0.03, 0.06), 1.0}, {Vec2(0.17, 0.06), 3.0}});
  EXPECT_FALSE(r.valid);
  EXPECT_EQ(r.status, TensionRaysStatus::Opposite);
  EXPECT_NEAR(r.theta, kPi, 1e-15);
  const double floor = TensionRaysParams{}.opening_floor;
  EXPECT_EQ(r.in_plane, floor);
  EXPECT_NEAR(r.energy_release * kThickness, floor * 4.0, 1e-12);
  TensionRaysParams none = params();
  none.opening_floor = 0;
  const TensionRays zero =
      rays_at(s, vertex_at(s, kSlitTip), {{Vec2(0.03, 0.06), 1.0}, {Vec2(0.17, 0.06), 3.0}}, Vec2::Zero(), none);
  EXPECT_LT(std::abs(zero.energy_release), 1e-12 * 4.0 / kThickness);
}

// A tip just past the line of two fingers pulling apart (θ a little under π, as demo's first tip 1 mm
// from its inner fingers' line): O'Keefe's weight cos(θ/2) is below the floor, so Er is the floor's share
// of the pull; farther from their line cos(θ/2) takes over again.
TEST(TensionRays, NearlyOppositePullsReadTheOpeningFloor) {
  const Sheet s = one_slit();
  const int32_t p = vertex_at(s, kSlitTip);
  const double floor = TensionRaysParams{}.opening_floor;
  const TensionRays near = rays_at(s, p, {{Vec2(0.0, 0.05), 1.0}, {Vec2(0.2, 0.05), 1.0}});  // 1 cm below, 10 cm off
  ASSERT_TRUE(near.valid);
  EXPECT_NEAR(near.theta, kPi - 2 * std::atan(0.1), 1e-12);
  ASSERT_LT(std::cos(0.5 * near.theta), floor);
  EXPECT_EQ(near.in_plane, floor);
  EXPECT_NEAR(near.energy_release * kThickness, floor * 2.0, 1e-12);
  const TensionRays far = rays_at(s, p, {{Vec2(0.07, 0.03), 1.0}, {Vec2(0.13, 0.03), 1.0}});  // θ = 90°
  ASSERT_TRUE(far.valid);
  EXPECT_NEAR(far.energy_release * kThickness, 2.0 * std::cos(0.25 * kPi), 1e-12);
}

// The result depends on positions only: a rigid motion of the pattern moves t with it.
TEST(TensionRays, InvariantUnderRigidMotionsOfThePattern) {
  const Sheet s0 = slit_grid(kW, kH, 20, 15, {Slit{6, 5}, Slit{12, 8}});
  const Eigen::Rotation2Dd rot(0.7);
  const Vec2 shift(1.3, -0.7);
  Sheet s1 = s0;
  for (Vec2& r : s1.verts.rest) r = rot * r + shift;
  const int32_t p = vertex_at(s0, Vec2(0.06, 0.05));
  std::vector<LoadPoint> loads{{vertex_at(s0, Vec2(0.03, 0.02)), Vec3(0.3, 0.1, 0.2)},
                               {vertex_at(s0, Vec2(0.16, 0.03)), Vec3(-0.5, 0, 0.4)},
                               {vertex_at(s0, Vec2(0.01, 0.10)), Vec3(0, 0.2, 0)}};
  TensionRaysScratch scratch;
  TensionRays r0, r1;
  compute_tension_rays(s0.verts.rest, s0.tris.piece, s0.topo, p, loads, params(), scratch, r0);
  compute_tension_rays(s1.verts.rest, s1.tris.piece, s1.topo, p, loads, params(), scratch, r1);
  ASSERT_TRUE(r0.valid);
  ASSERT_TRUE(r1.valid);
  EXPECT_FALSE(r0.rays[1].straight);
  EXPECT_NEAR((r1.direction - rot * r0.direction).norm(), 0, 1e-9);
  EXPECT_NEAR(r1.theta, r0.theta, 1e-9);
  EXPECT_NEAR(r1.energy_release, r0.energy_release, 1e-9 * r0.energy_release);
  EXPECT_EQ(r1.left_count, r0.left_count);
}

// Mesh independence: the same notched outline meshed with different seeds and orientations gives the
// same t (to 1e-9), with straight paths and with a path bent at an outline corner.
TEST(TensionRays, SameOutlineOnDifferentMeshesGivesTheSameDirection) {
  const std::vector<Vec2> outline{{0, 0},     {0.12, 0},   {0.12, 0.10}, {0.13, 0.10}, {0.13, 0},
                                  {0.2, 0},   {0.2, 0.15}, {0.07, 0.15}, {0.06, 0.08}, {0.05, 0.15},
                                  {0, 0.15}};
  const Vec2 P(0.06, 0.08);
  const std::vector<Vec2> fingers{{0.02, 0.03}, {0.10, 0.07}, {0.17, 0.03}};
  const std::vector<double> force{0.6, 0.3, 0.8};
  struct Case {
    std::vector<int> use;
    bool straight;
  };
  for (const Case& c : {Case{{0, 1}, true}, Case{{0, 2}, false}}) {
    std::vector<Vec2> reference;
    for (const auto& [seed, rotation] : std::vector<std::pair<uint64_t, double>>{{0, 0}, {1, 0}, {7, 23}, {3, 61}}) {
      MeshRequest req;
      req.outline = outline;
      req.required_points = fingers;
      req.target_triangles = 300;
      req.seed = seed;
      req.rotation_deg = rotation;
      std::vector<int32_t> held;
      const Sheet s = meshed(req, held);
      std::vector<LoadPoint> loads;
      for (int k : c.use) loads.push_back(LoadPoint{held[k], Vec3(force[k], 0, 0)});
      TensionRaysScratch scratch;
      TensionRays r;
      compute_tension_rays(s.verts.rest, s.tris.piece, s.topo, vertex_at(s, P), loads, params(), scratch, r);
      ASSERT_TRUE(r.valid) << seed;
      EXPECT_EQ(r.rays[1].straight, c.straight);
      reference.push_back(r.direction);
    }
    for (size_t k = 1; k < reference.size(); ++k) EXPECT_NEAR((reference[k] - reference[0]).norm(), 0, 1e-9);
  }
}

// Same call twice on one scratch: bit-identical, and no new allocation the second time.
TEST(TensionRays, DeterministicAndReusesItsBuffers) {
  const Sheet s = slit_grid(kW, kH, 20, 15, {Slit{6, 5}, Slit{12, 8}});
  const int32_t p = vertex_at(s, Vec2(0.06, 0.05));
  const std::vector<LoadPoint> loads{{vertex_at(s, Vec2(0.03, 0.02)), Vec3(0.7, 0, 0)},
                                     {vertex_at(s, Vec2(0.16, 0.03)), Vec3(0, 0.9, 0)}};
  TensionRaysScratch scratch;
  TensionRays a, b;
  compute_tension_rays(s.verts.rest, s.tris.piece, s.topo, p, loads, params(), scratch, a);
  const void* edges = scratch.boundary.edges.data();
  const void* rays = a.rays.data();
  compute_tension_rays(s.verts.rest, s.tris.piece, s.topo, p, loads, params(), scratch, a);
  EXPECT_EQ(scratch.boundary.edges.data(), edges);
  EXPECT_EQ(a.rays.data(), rays);
  TensionRaysScratch fresh;
  compute_tension_rays(s.verts.rest, s.tris.piece, s.topo, p, loads, params(), fresh, b);
  EXPECT_EQ(a.direction, b.direction);
  EXPECT_EQ(a.energy_release, b.energy_release);
  EXPECT_EQ(a.iterations, b.iterations);
}

// Cost of one call on a ~300-triangle sheet with a slit, one path bent (printed, not checked).
TEST(TensionRays, CostOnASmallSlitSheet) {
  const Sheet s = slit_grid(0.15, 0.15, 12, 12, {Slit{6, 7}});
  ASSERT_EQ(s.tris.size(), 288);
  const int32_t p = vertex_at(s, Vec2(0.0375, 0.0));
  const std::vector<LoadPoint> loads{{vertex_at(s, Vec2(0.0125, 0.0875)), Vec3(0.7, 0, 0)},
                                     {vertex_at(s, Vec2(0.125, 0.025)), Vec3(0, 0.9, 0)}};
  TensionRaysScratch scratch;
  TensionRays r;
  compute_tension_rays(s.verts.rest, s.tris.piece, s.topo, p, loads, params(), scratch, r);
  ASSERT_EQ(r.rays.size(), 2u);
  EXPECT_FALSE(r.rays[1].straight);
  const int calls = 20000;
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < calls; ++i)
    compute_tension_rays(s.verts.rest, s.tris.piece, s.topo, p, loads, params(), scratch, r);
  const double us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count() / calls;
  std::printf("compute_tension_rays, 288 triangles, %zu boundary edges, one bent path: %.2f us per call, "
              "%d segment tests\n", scratch.boundary.edges.size(), us, r.paths.visibility_tests);
  RecordProperty("microseconds_per_call", std::to_string(us));

  // 10 000 triangles, five slits (five reflex tips), a path bent at one of them.
  const Sheet big = slit_grid(0.3, 0.21, 100, 50, {Slit{20, 30}, Slit{35, 20}, Slit{50, 35}, Slit{65, 25}, Slit{80, 30}});
  ASSERT_EQ(big.tris.size(), 10000);
  const int32_t q = vertex_at(big, Vec2(0.06, 30 * 0.0042));
  const std::vector<LoadPoint> far{{vertex_at(big, Vec2(0.0, 0.0)), Vec3(0.7, 0, 0)},
                                   {vertex_at(big, Vec2(0.18, 0.0)), Vec3(0, 0.9, 0)}};
  compute_tension_rays(big.verts.rest, big.tris.piece, big.topo, q, far, params(), scratch, r);
  ASSERT_EQ(r.rays.size(), 2u);
  EXPECT_FALSE(r.rays[1].straight);
  const int big_calls = 2000;
  const auto t1 = std::chrono::steady_clock::now();
  for (int i = 0; i < big_calls; ++i)
    compute_tension_rays(big.verts.rest, big.tris.piece, big.topo, q, far, params(), scratch, r);
  const double big_us =
      std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t1).count() / big_calls;
  std::printf("compute_tension_rays, 10000 triangles, %zu boundary edges, %zu reflex: %.2f us per call, "
              "%d segment tests, path of %d points\n", scratch.boundary.edges.size(), scratch.boundary.reflex.size(),
              big_us, r.paths.visibility_tests, r.paths.paths[1].point_end - r.paths.paths[1].point_begin);
}

// A hand's fingers move as one body, so the split keeps them on one side (the side with more of the hand's
// weight): a tip that has grown up from the border past one finger of the right hand (R1, below right)
// with the hand's other finger (R2) nearly straight ahead, a little to the left, splits the hand without it
// and runs between R1 and R2, as fig12-junction's tear did (docs/tearing.md, "Direction and Er at a tip").
TEST(TensionRays, AHandsFingersStayOnOneSideOfTheSplit) {
  const Sheet s = one_slit();
  const int32_t p = vertex_at(s, kSlitTip);
  struct HeldPoint {
    Vec2 at;
    double force;
    int32_t hand;
  };
  const std::vector<HeldPoint> fingers{{{0.02, 0.03}, 0.8, 0}, {{0.02, 0.12}, 0.8, 0},  // left hand, pulling up
                                    {{0.12, 0.03}, 1.0, 1}, {{0.09, 0.14}, 0.5, 1}}; // right hand, down
  std::vector<LoadPoint> loads;
  for (const HeldPoint& f : fingers)
    loads.push_back(LoadPoint{vertex_at(s, f.at), Vec3(0, 0, f.hand == 0 ? f.force : -f.force), f.hand});
  TensionRaysScratch scratch;
  auto sides = [&](bool whole) {
    TensionRaysParams rp = params();
    rp.previous_direction = Vec2(0, 1);
    rp.hands_whole = whole;
    TensionRays out;
    compute_tension_rays(s.verts.rest, s.tris.piece, s.topo, p, loads, rp, scratch, out);
    EXPECT_EQ(out.rays.size(), 4u);
    std::vector<int32_t> side(4, 0);
    for (const LoadRay& r : out.rays) side[r.load] = r.side;
    return std::make_pair(out, side);
  };
  const auto [apart, apart_sides] = sides(false);
  EXPECT_EQ(apart_sides, (std::vector<int32_t>{1, 1, -1, 1})) << "the plain split puts R2 with the left hand";
  const auto [whole, whole_sides] = sides(true);
  ASSERT_TRUE(whole.valid);
  EXPECT_EQ(whole_sides, (std::vector<int32_t>{1, 1, -1, -1}));
  // Between the hands, not between R1 and R2: t runs up and away from the right hand's side.
  EXPECT_GT(whole.direction.y(), 0);
  EXPECT_LT(whole.direction.x(), apart.direction.x());
}
