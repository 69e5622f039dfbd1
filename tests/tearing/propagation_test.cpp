// Energy release rate, Griffith's test and the tear direction (paper eqs. 1, 2, 6; docs/tearing.md
// "The fan rule", "How far"), checked against O'Keefe's two-finger analysis and a trouser-like pull, on
// hand-built fans.
#include "systems/tearing/propagation.hpp"
#include "systems/common/topology.hpp"

#include "tests/test_meshes.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <numbers>

using namespace pt;

namespace {

constexpr double kPi = std::numbers::pi;

using test::fan_sheet;
using test::flat;
using test::polar;

// A notch opening toward +y with its tip at vertex 0: the sheet covers every direction from p except
// the wedge between 80° and 100°. Interior angle 340°.
Sheet notch_sheet() { return fan_sheet({100, 140, 180, 225, 270, 315, 360, 400, 440}); }

// Clusters of a flat sheet: the pattern pre-images equal the forces.
ForceClusters flat_clusters(const Vec2& left, const Vec2& right) {
  ForceClusters c;
  c.left = flat(left);
  c.right = flat(right);
  c.left_pattern = left;
  c.right_pattern = right;
  c.left_count = c.right_count = 1;
  c.normal = Vec3::UnitZ();
  return c;
}

PropagationParams params(double speed = 2e-7, double max_step = 0.01) {
  PropagationParams p;
  p.thickness = 1e-4;
  p.speed = speed;
  p.max_step = max_step;
  return p;
}

}  // namespace

// φ = 0 (trouser tear): both forces point back out of the notch. Er = (‖F_l‖ + ‖F_r‖) / e exactly and the
// tear runs straight ahead, into the material.
TEST(Propagation, ForcesBehindTheTipReleaseEverything) {
  const Sheet s = notch_sheet();
  ASSERT_NEAR(interior_pattern_angle(s.topo, s.verts.rest, 0), 340 * kPi / 180, 1e-12);
  const ForceClusters c = flat_clusters(Vec2(0, 2), Vec2(0, 3));
  const PropagationDecision d = decide_propagation(c, s.topo, s.verts.rest, 0, 0.0, params());
  EXPECT_EQ(d.angle, 0.0);
  EXPECT_NEAR(d.energy_release, 5.0 / 1e-4, 1e-12 * 5e4);
  EXPECT_NEAR((d.direction - Vec2(0, -1)).norm(), 0, 1e-15);
  EXPECT_TRUE(d.into_material);
  EXPECT_TRUE(d.propagate);
}

// φ = π: opposite in-plane pulls never tear, whatever their magnitude and even with no resistance.
TEST(Propagation, OppositeInPlanePullsNeverTear) {
  const Sheet s = notch_sheet();
  for (double m : {1e-6, 1.0, 1e3, 1e9}) {
    for (const Vec2& dir : {Vec2(1, 0), Vec2(0, 1), Vec2(0.6, -0.8)}) {
      const ForceClusters c = flat_clusters(-m * dir, m * dir);
      const PropagationDecision d = decide_propagation(c, s.topo, s.verts.rest, 0, 0.0, params());
      EXPECT_NEAR(d.angle, kPi, 1e-15);
      EXPECT_LE(d.energy_release, 1e-12 * 2 * m / 1e-4);
      EXPECT_FALSE(d.propagate) << m;
    }
  }
}

// O'Keefe (paper eq. 2, Fig. 2): fingers at pattern points A and B pull p toward themselves. The tear
// direction is −bisector of PA and PB, which is tangent to the hyperbola |PA| − |PB| = const (it is
// orthogonal to that function's gradient unit(P−A) − unit(P−B)), and Er = (F_A + F_B) cos(θ/2) / e with
// θ the angle APB.
TEST(Propagation, TwoFingersGiveTheHyperbolaTangent) {
  const Sheet s = notch_sheet();
  const Vec2 p = s.verts.rest[0];
  const Vec2 A(-0.5, 1.0), B(0.8, 0.6);
  const Vec2 ua = (A - p).normalized(), ub = (B - p).normalized();
  const double fa = 0.7, fb = 1.3;
  const ForceClusters c = flat_clusters(fa * ua, fb * ub);
  const PropagationDecision d = decide_propagation(c, s.topo, s.verts.rest, 0, 0.0, params());
  const Vec2 expected = -(ua + ub).normalized();
  EXPECT_NEAR((d.direction - expected).norm(), 0, 1e-14);
  EXPECT_NEAR(d.direction.dot(ua - ub), 0, 1e-14);
  const double theta = std::acos(ua.dot(ub));
  EXPECT_NEAR(d.angle, theta, 1e-12);
  EXPECT_NEAR(d.energy_release, (fa + fb) * std::cos(theta / 2) / 1e-4, 1e-9);
  EXPECT_TRUE(d.propagate);

  // Symmetric fingers: the tear follows the mediator of AB (paper Fig. 14).
  const ForceClusters sym = flat_clusters(Vec2(-0.6, 0.8), Vec2(0.6, 0.8));
  EXPECT_NEAR((decide_propagation(sym, s.topo, s.verts.rest, 0, 0.0, params()).direction - Vec2(0, -1)).norm(),
              0, 1e-15);
}

// Following the tear step by step with fixed fingers keeps |PA| − |PB| constant (the path is O'Keefe's
// hyperbola, paper Fig. 15). The notch is carried along with the tip so p stays a tear tip.
TEST(Propagation, TwoFingerPathStaysOnTheHyperbola) {
  Sheet s = notch_sheet();
  const Vec2 A(-0.4, 1.2), B(0.9, 0.3);
  const std::vector<Vec2> ring = s.verts.rest;
  Vec2 p = Vec2::Zero();
  const double invariant = (p - A).norm() - (p - B).norm();
  const PropagationParams prm = params(1.0, 1e-3);  // k·Er ≫ 1e-3: every step is the cap
  double travelled = 0;
  for (int i = 0; i < 300; ++i) {
    for (size_t v = 0; v < ring.size(); ++v) s.verts.rest[v] = ring[v] + p;
    const ForceClusters c = flat_clusters((A - p).normalized(), (B - p).normalized());
    const PropagationDecision d = decide_propagation(c, s.topo, s.verts.rest, 0, 0.0, prm);
    ASSERT_TRUE(d.propagate) << i;
    travelled += (d.next - p).norm();
    p = d.next;
  }
  EXPECT_NEAR(travelled, 0.3, 1e-12);
  EXPECT_NEAR((p - A).norm() - (p - B).norm(), invariant, 2e-4);
  EXPECT_LT(p.y(), -0.2);  // it did go into the sheet, away from the fingers
}

// Griffith (eq. 1): Er ≥ Ef.
TEST(Propagation, GriffithThreshold) {
  const Sheet s = notch_sheet();
  const ForceClusters c = flat_clusters(Vec2(-0.3, 0.5), Vec2(0.4, 0.45));
  const double er = decide_propagation(c, s.topo, s.verts.rest, 0, 0.0, params()).energy_release;
  ASSERT_GT(er, 0);
  EXPECT_FALSE(decide_propagation(c, s.topo, s.verts.rest, 0, er * (1 + 1e-9), params()).propagate);
  EXPECT_TRUE(decide_propagation(c, s.topo, s.verts.rest, 0, er * (1 - 1e-9), params()).propagate);
  EXPECT_TRUE(decide_propagation(c, s.topo, s.verts.rest, 0, er, params()).propagate);
}

// p_next = p + min(k·Er, max_step)·t, lengthened to min_step.
TEST(Propagation, StepLengthIsCapped) {
  Sheet s = notch_sheet();
  for (Vec2& r : s.verts.rest) r += Vec2(0.05, 0.1);
  const Vec2 p = s.verts.rest[0];
  const ForceClusters c = flat_clusters(Vec2(0, 0.5), Vec2(0, 0.5));  // Er = 1e4
  PropagationParams prm = params(2e-7, 0.01);
  PropagationDecision d = decide_propagation(c, s.topo, s.verts.rest, 0, 0.0, prm);
  ASSERT_TRUE(d.propagate);
  EXPECT_NEAR((d.next - (p + Vec2(0, -2e-3))).norm(), 0, 1e-15);  // k·Er = 2 mm under the cap
  prm.max_step = 1e-3;
  d = decide_propagation(c, s.topo, s.verts.rest, 0, 0.0, prm);
  EXPECT_NEAR((d.next - p).norm(), 1e-3, 1e-15);
  prm.max_step = 0.01;
  prm.min_step = 5e-3;
  d = decide_propagation(c, s.topo, s.verts.rest, 0, 0.0, prm);
  EXPECT_NEAR((d.next - p).norm(), 5e-3, 1e-15);
}

// Forces that point into the material push the tear out of the sheet (into the notch): no propagation.
// The sweep checks into_material against the notch's empty wedge (80°, 100°) for directions all around.
TEST(Propagation, DirectionOutOfTheSheetDoesNotTear) {
  const Sheet s = notch_sheet();
  const ForceClusters in = flat_clusters(Vec2(-0.2, -1), Vec2(0.2, -1));
  const PropagationDecision d = decide_propagation(in, s.topo, s.verts.rest, 0, 0.0, params());
  EXPECT_GT(d.energy_release, 0);
  EXPECT_NEAR((d.direction - Vec2(0, 1)).norm(), 0, 1e-15);
  EXPECT_FALSE(d.into_material);
  EXPECT_FALSE(d.propagate);
  for (int deg = 0; deg < 360; deg += 5) {
    const Vec2 t = polar(deg + 0.5);
    const ForceClusters c = flat_clusters(-t, -t);  // φ = 0, t exactly this direction
    const PropagationDecision e = decide_propagation(c, s.topo, s.verts.rest, 0, 0.0, params());
    const bool in_notch = deg + 0.5 > 80 && deg + 0.5 < 100;
    EXPECT_EQ(e.into_material, !in_notch) << deg;
    EXPECT_EQ(e.propagate, !in_notch) << deg;
  }
}

// A convex corner (interior angle 90°, sheet in the first quadrant): only directions inside the quadrant
// tear; along an edge is not inside.
TEST(Propagation, ConvexCornerInteriorAngle) {
  const Sheet s = fan_sheet({0, 45, 90});
  auto into = [&](const Vec2& t) {
    return decide_propagation(flat_clusters(-t, -t), s.topo, s.verts.rest, 0, 0.0, params()).into_material;
  };
  EXPECT_TRUE(into(polar(45)));
  EXPECT_TRUE(into(polar(1)));
  EXPECT_TRUE(into(polar(89)));
  EXPECT_FALSE(into(polar(0)));
  EXPECT_FALSE(into(polar(90)));
  EXPECT_FALSE(into(polar(135)));
  EXPECT_FALSE(into(polar(-45)));
  EXPECT_FALSE(into(polar(225)));
}

TEST(Propagation, DegenerateInputsDoNotTear) {
  const Sheet s = notch_sheet();
  ForceClusters one = flat_clusters(Vec2(0, 1), Vec2(0, 1));
  one.right_count = 0;
  one.right = Vec3::Zero();
  one.right_pattern = Vec2::Zero();
  EXPECT_FALSE(decide_propagation(one, s.topo, s.verts.rest, 0, 0.0, params()).propagate);
  ForceClusters nan = flat_clusters(Vec2(0, 1), Vec2(0, 1));
  nan.left_pattern.x() = std::nan("");
  EXPECT_FALSE(decide_propagation(nan, s.topo, s.verts.rest, 0, 0.0, params()).propagate);
  ForceClusters inf = flat_clusters(Vec2(0, 1), Vec2(0, 1));
  inf.left.z() = INFINITY;
  EXPECT_FALSE(decide_propagation(inf, s.topo, s.verts.rest, 0, 0.0, params()).propagate);
  // An interior vertex has no interior angle: nothing is "into" the sheet from it.
  Sheet closed = fan_sheet({0, 90, 180, 270});
  closed.tris.resize(4);
  closed.tris.tri[3] = Tri{0, 4, 1};
  refresh_after_topology_change(closed);
  EXPECT_FALSE(decide_propagation(flat_clusters(Vec2(0, 1), Vec2(0, 1)), closed.topo, closed.verts.rest, 0, 0.0,
                                  params()).propagate);
}

// Trouser-like pull, from corner forces to the decision: at a notch tip the two lips are folded out of
// the sheet, one up and one down (the legs of a trouser test: each lip rotated ±90° about the in-plane
// axis through p perpendicular to the tear). A finger force of magnitude F pulls each lip, nearly along
// ±z, so the 3D forces at p are opposite; their pre-images both point back toward the lips (φ = 2β), and
// the tear starts when 2 F cos β / e reaches Ef, i.e. at F ≈ Ef·e/2. The same forces in a flat in-plane
// pull (lips drawn apart sideways) never tear.
TEST(Propagation, TrouserPullStartsAtHalfEfTimesThickness) {
  Sheet s = notch_sheet();
  for (int32_t v = 0; v < s.verts.size(); ++v) {
    const Vec2 r = s.verts.rest[v];
    s.verts.x[v] = r.y() <= 0 ? flat(r) : r.x() < 0 ? Vec3(r.x(), 0, r.y()) : Vec3(r.x(), 0, -r.y());
  }
  const double beta = 10 * kPi / 180;
  const Vec3 up(-std::sin(beta), 0, std::cos(beta)), down(std::sin(beta), 0, -std::cos(beta));
  const double e = 1e-4, ef = 3000;
  const PropagationParams prm = params();
  auto decide = [&](Sheet& sheet, const Vec3& left_dir, const Vec3& right_dir, double F, ForceClusters& c) {
    for (auto& fc : sheet.tris.corner_force) fc[0] = Vec3::Zero();
    sheet.tris.corner_force[0][0] = sheet.tris.corner_force[1][0] = 0.5 * F * left_dir;  // left lip
    sheet.tris.corner_force[6][0] = sheet.tris.corner_force[7][0] = 0.5 * F * right_dir; // right lip
    EXPECT_TRUE(cluster_tip_forces(sheet.verts, sheet.tris, sheet.topo, 0, ClusterParams{}, c));
    return decide_propagation(c, sheet.topo, sheet.verts.rest, 0, ef, prm);
  };

  ForceClusters c;
  const PropagationDecision d = decide(s, up, down, 1.0, c);
  EXPECT_NEAR(c.left.normalized().dot(c.right.normalized()), -1, 1e-14);
  EXPECT_GT(c.left_pattern.y(), 0);
  EXPECT_GT(c.right_pattern.y(), 0);
  EXPECT_NEAR(d.angle, 2 * beta, 1e-9);
  EXPECT_NEAR((d.direction - Vec2(0, -1)).norm(), 0, 1e-12);
  EXPECT_TRUE(d.into_material);

  // Threshold by bisection on F.
  double lo = 0, hi = 10 * ef * e;
  ASSERT_FALSE(decide(s, up, down, lo, c).propagate);
  ASSERT_TRUE(decide(s, up, down, hi, c).propagate);
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (decide(s, up, down, mid, c).propagate ? hi : lo) = mid;
  }
  EXPECT_NEAR(hi / (ef * e / 2), 1, 0.05);
  EXPECT_NEAR(hi, ef * e / (2 * std::cos(beta)), 1e-9 * hi);

  // Flat sheet, lips pulled apart in the plane: opposite pre-images, no tear even at 100× the force.
  Sheet flat_sheet = notch_sheet();
  const PropagationDecision f = decide(flat_sheet, Vec3(-1, 0, 0), Vec3(1, 0, 0), 100 * ef * e, c);
  EXPECT_NEAR(f.angle, kPi, 1e-12);
  EXPECT_FALSE(f.propagate);
}

// The frame skips clustering a candidate whose fan_force_sum / e is below its fracture energy, which is
// exact only if Er ≤ Σ‖f_k‖ / e for every split eq. 4 can make: random forces on a notch fan, bent 3D
// positions, any φ.
TEST(Propagation, FanForceSumBoundsTheEnergyReleaseRate) {
  Sheet s = notch_sheet();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const PropagationParams prm = params();
  int propagating = 0;
  for (int trial = 0; trial < 500; ++trial) {
    for (int32_t v = 1; v < s.verts.size(); ++v) s.verts.x[v] = flat(s.verts.rest[v]) + 0.2 * Vec3(u(rng), u(rng), u(rng));
    for (auto& fc : s.tris.corner_force) fc[0] = 10 * Vec3(u(rng), u(rng), 0.3 * u(rng));
    ForceClusters c;
    ASSERT_TRUE(cluster_tip_forces(s.verts, s.tris, s.topo, 0, ClusterParams{}, c));
    const PropagationDecision d = decide_propagation(c, s.topo, s.verts.rest, 0, 0.0, prm);
    const double bound = fan_force_sum(s.tris, s.topo, 0) / prm.thickness;
    EXPECT_LE(d.energy_release, bound * (1 + 1e-12)) << "trial " << trial;
    propagating += d.propagate;
  }
  EXPECT_GT(propagating, 50) << "the trials include propagating tips";
  // A non-finite force makes the bound NaN, which the frame treats as "skip" (the decision refuses it too).
  s.tris.corner_force[0][0] = Vec3(std::nan(""), 0, 0);
  EXPECT_TRUE(std::isnan(fan_force_sum(s.tris, s.topo, 0)));
}

// A driving direction (the crack driving force of systems/tearing/material_force.hpp) replaces the bisector as t;
// Er, φ and Griffith's test stay those of the clusters, and t must still point into the material.
TEST(Propagation, DrivingDirectionReplacesTheBisector) {
  const Sheet s = notch_sheet();
  const ForceClusters c = flat_clusters(Vec2(-1, 2), Vec2(1, 3));
  PropagationParams with = params();
  with.driving_direction = Vec2(3, -4);  // not unit: normalised
  const PropagationDecision bisector = decide_propagation(c, s.topo, s.verts.rest, 0, 0.0, params());
  const PropagationDecision d = decide_propagation(c, s.topo, s.verts.rest, 0, 0.0, with);
  EXPECT_NEAR((d.direction - Vec2(0.6, -0.8)).norm(), 0, 1e-15);
  EXPECT_EQ(d.energy_release, bisector.energy_release);
  EXPECT_EQ(d.angle, bisector.angle);
  EXPECT_TRUE(d.propagate);
  const double step = std::min(2e-7 * d.energy_release, 0.01);
  EXPECT_NEAR((d.next - (s.verts.rest[0] + step * Vec2(0.6, -0.8))).norm(), 0, 1e-15);
  // Out of the notch (the wedge between 80° and 100°): not into the material, no propagation.
  with.driving_direction = Vec2(0, 1);
  const PropagationDecision out = decide_propagation(c, s.topo, s.verts.rest, 0, 0.0, with);
  EXPECT_FALSE(out.into_material);
  EXPECT_FALSE(out.propagate);
  // Not finite: refused.
  with.driving_direction = Vec2(std::nan(""), 1);
  EXPECT_FALSE(decide_propagation(c, s.topo, s.verts.rest, 0, 0.0, with).propagate);
}
