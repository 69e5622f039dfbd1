// Griffith's decision from the tension rays (systems/tearing/tension_ray_decision.hpp): the trouser
// calibration Er = (F_L + F_R)/e, and where a tear may start (on the load's path between the two sides).
#include "systems/tearing/tension_ray_decision.hpp"
#include "systems/common/topology.hpp"

#include "tests/test_meshes.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>

using namespace pt;
using test::slit_grid;
using test::vertex_at;

namespace {

constexpr double kThickness = 1e-4;

PropagationParams propagation() {
  PropagationParams p;
  p.thickness = kThickness;
  p.min_step = 0.002;
  return p;
}

// A finger holding the vertex at `at` (the copy on `side` of a lip) that pulls it out of the sheet's plane
// with `force`: up (+z) for `up`, else down, as a trouser's legs are pulled apart.
void hold(Sheet& s, const Vec2& at, const Vec2& side, double force, bool up) {
  Finger f;
  f.vertex = vertex_at(s, at, side);
  ASSERT_GE(f.vertex, 0);
  f.reaction = Vec3(0, 0, up ? force : -force);
  s.fingers.push_back(f);
}

}  // namespace

// A trouser test: a slit from the bottom edge, the two legs held at the slit's mouth and pulled apart, one
// up and one down. Both pulls are behind the tip (θ = 0): Er = (F_L + F_R)/e, so the tear
// starts when each finger holds Ef · e / 2.
TEST(TensionRayDecision, TrouserPullTearsAtEfTimesThicknessOverTwo) {
  Sheet s = slit_grid(0.2, 0.15, 10, 6, {{5, 3}});
  const int32_t tip = vertex_at(s, Vec2(0.1, 0.075));
  const double ef = 2e4, threshold = ef * kThickness / 2;
  for (const double scale : {0.999, 1.001}) {
    s.fingers.clear();
    hold(s, Vec2(0.1, 0), Vec2(-1, 0.1), scale * threshold, true);
    hold(s, Vec2(0.1, 0), Vec2(1, 0.1), scale * threshold, false);
    TensionRayDecisionScratch scratch;
    const PropagationDecision d =
        decide_by_tension_rays(s, tip, ef, false, propagation(), MembraneParams{}, TensionRayDecisionParams{}, scratch);
    EXPECT_EQ(d.griffith, scale > 1) << "scale " << scale;
    if (scale > 1) {
      EXPECT_NEAR(d.angle, 0, 1e-12);
      EXPECT_NEAR(d.energy_release, 2 * scale * threshold / kThickness, 1e-6);
    }
    EXPECT_EQ(d.propagate, scale > 1);
    if (d.propagate) {
      EXPECT_TRUE(d.direction.isApprox(Vec2(0, 1), 1e-12)) << "straight on, away from the legs";
      const PropagationParams pp = propagation();
      const double step = std::clamp(pp.speed * d.energy_release, pp.min_step, pp.max_step);  // p + k Er t, bounded
      EXPECT_TRUE(d.next.isApprox(Vec2(0.1, 0.075 + step), 1e-12));
    }
  }
}

// Two fingers left and right of a slit near the bottom edge: the tension between them wraps around the
// slit's tip, so a tear may start there, but not from a point of the slit's lips nor from the outline,
// which the load passes by.
TEST(TensionRayDecision, StartsOnlyWhereTheLoadBetweenTheSidesPasses) {
  Sheet s = slit_grid(0.2, 0.15, 10, 6, {{5, 3}});
  hold(s, Vec2(0.06, 0.025), Vec2::Zero(), 1.0, true);
  hold(s, Vec2(0.14, 0.025), Vec2::Zero(), 1.0, false);
  TensionRayDecisionScratch scratch;
  const TensionRayDecisionParams params;
  auto excess_at = [&](const Vec2& at, const Vec2& side) {
    const int32_t p = vertex_at(s, at, side);
    EXPECT_GE(p, 0);
    finger_load_points(s.fingers, scratch.loads);
    TensionRaysParams rp;
    compute_tension_rays(s.verts.rest, s.tris.piece, s.topo, p, scratch.loads, rp, scratch.rays, scratch.result);
    return start_wrap_excess(s, scratch.result, scratch.loads, scratch);
  };
  EXPECT_NEAR(excess_at(Vec2(0.1, 0.075), Vec2::Zero()), 0, 1e-12) << "the tip is on the path";
  EXPECT_GT(excess_at(Vec2(0.1, 0.05), Vec2(-1, 0)), params.start_wrap) << "a lip";
  EXPECT_GT(excess_at(Vec2(0.1, 0.15), Vec2::Zero()), params.start_wrap) << "the top edge";
  // The decision itself: with Er well above Ef the tip starts a tear, the top edge does not.
  const int32_t tip = vertex_at(s, Vec2(0.1, 0.075));
  const PropagationDecision at_tip =
      decide_by_tension_rays(s, tip, 10.0, true, propagation(), MembraneParams{}, params, scratch);
  EXPECT_TRUE(at_tip.propagate);
  EXPECT_GT(at_tip.direction.y(), 0.99) << "along the mediator, away from the fingers";
  const int32_t top = vertex_at(s, Vec2(0.1, 0.15));
  EXPECT_FALSE(decide_by_tension_rays(s, top, 10.0, true, propagation(), MembraneParams{}, params, scratch).propagate);
}

// The same trouser with both legs pulled the same way (the sheet held up by both): nothing pulls the sides
// apart, so nothing tears, however large the forces.
TEST(TensionRayDecision, LegsPulledTheSameWayDoNotTear) {
  Sheet s = slit_grid(0.2, 0.15, 10, 6, {{5, 3}});
  const int32_t tip = vertex_at(s, Vec2(0.1, 0.075));
  hold(s, Vec2(0.1, 0), Vec2(-1, 0.1), 10.0, true);
  hold(s, Vec2(0.1, 0), Vec2(1, 0.1), 10.0, true);
  TensionRayDecisionScratch scratch;
  const PropagationDecision same =
      decide_by_tension_rays(s, tip, 2e4, false, propagation(), MembraneParams{}, TensionRayDecisionParams{}, scratch);
  EXPECT_FALSE(same.griffith);
  EXPECT_NEAR(same.energy_release, 0, 1e-9);
  s.fingers[1].reaction = -s.fingers[1].reaction;
  const PropagationDecision apart =
      decide_by_tension_rays(s, tip, 2e4, false, propagation(), MembraneParams{}, TensionRayDecisionParams{}, scratch);
  EXPECT_TRUE(apart.propagate);
  EXPECT_NEAR(apart.energy_release, 20.0 / kThickness, 1e-6);
}

// The same trouser with its legs pushed or pulled in the sheet's plane (sensed_energy_release): pulled
// apart (the left leg to the left) the tear opens, Er = (F_L + F_R)/e as out of the plane; pushed together,
// the same forces with the opposite sense close it and release nothing. The decision reads the sense in the
// material ahead of the tip, so a rigid motion of the whole sheet changes nothing.
TEST(TensionRayDecision, LegsPushedTogetherInThePlaneDoNotTear) {
  const Sheet flat = slit_grid(0.2, 0.15, 10, 6, {{5, 3}});
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.9, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  for (const bool turned : {false, true}) {
    Sheet s = flat;
    const Mat3 r = turned ? turn : Mat3::Identity();
    for (Vec3& x : s.verts.x) x = r * x;
    const int32_t tip = vertex_at(s, Vec2(0.1, 0.075));
    hold(s, Vec2(0.1, 0), Vec2(-1, 0.1), 10.0, true);
    hold(s, Vec2(0.1, 0), Vec2(1, 0.1), 10.0, true);
    auto decide = [&](double sense) {
      s.fingers[0].reaction = r * Vec3(-sense * 10.0, 0, 0);  // the left leg (x < 0.1)
      s.fingers[1].reaction = r * Vec3(sense * 10.0, 0, 0);
      TensionRayDecisionScratch scratch;
      return decide_by_tension_rays(s, tip, 2e4, false, propagation(), MembraneParams{}, TensionRayDecisionParams{},
                                    scratch);
    };
    const PropagationDecision apart = decide(1), together = decide(-1);
    EXPECT_TRUE(apart.propagate) << "turned " << turned;
    EXPECT_NEAR(apart.energy_release, 20.0 / kThickness, 1e-6) << "turned " << turned;
    EXPECT_FALSE(together.griffith) << "turned " << turned;
    EXPECT_NEAR(together.energy_release, 0, 1e-6) << "turned " << turned;
  }
}

// An edge start (a straight border, no notch): the sheet stretched 1% along x carries ~120 N/m along its top
// edge, far above a start's tension, everywhere on it. With the two fingers 5 mm below that edge, the load
// between them passes the edge's midpoint and a tear starts there; with the same fingers 10 cm below it the
// edge is as taut but the load passes far off it (d(A, p) + d(p, B) − d(A, B) = 11 cm), and nothing starts.
// Without the loads' path the second sheet would tear from its top edge as the first does.
TEST(TensionRayDecision, AnEdgeStartsOnlyWhereTheLoadBetweenTheSidesPasses) {
  Material paper;
  const MembraneParams membrane = membrane_params(paper);
  const TensionRayDecisionParams params;
  for (const double below : {0.005, 0.1}) {
    Sheet s = slit_grid(0.2, 0.15, 20, 30, {});
    for (Vec3& x : s.verts.x) x.x() *= 1.01;
    hold(s, Vec2(0.04, 0.15 - below), Vec2::Zero(), 1.0, true);
    hold(s, Vec2(0.16, 0.15 - below), Vec2::Zero(), 1.0, false);
    const int32_t p = vertex_at(s, Vec2(0.1, 0.15));
    ASSERT_GE(p, 0);
    TensionRayDecisionScratch scratch;
    const PropagationDecision d = decide_edge_start(s, p, 1e3, propagation(), membrane, params, scratch);
    const double excess = start_wrap_excess(s, scratch.result, scratch.loads, scratch);
    EXPECT_GT(d.energy_release, 10 * 1e3) << below << ": the edge is taut either way";
    if (below < 0.01) {
      EXPECT_LT(excess, params.start_wrap);
      EXPECT_TRUE(d.propagate) << "on the load's path";
      EXPECT_LT(d.direction.y(), -0.99) << "into the sheet, across the edge";
    } else {
      EXPECT_NEAR(excess, 2 * (std::hypot(0.06, 0.1) - 0.06), 1e-9);
      EXPECT_FALSE(d.griffith) << "the load passes 10 cm below";
      EXPECT_FALSE(d.propagate);
    }
  }
}

// A lip beside a notch: a trouser's legs held 1 cm either side of the slit's mouth, the sheet stretched 1%
// along the slit so its lips are taut far above a start's tension. A lip point 1.5 cm below the slit's tip
// lies on the load's path (d(A, p) + d(p, B) − d(A, B) = 0.16 mm, within start_wrap), but the path from one
// leg's finger to the other bends round the tip, where the load concentrates: the lip does not start a
// tear, the tip does. (Under the compression relief a leg's inner edge carries the whole pull, and its lips
// started tears that cut the leg off on 2 of 9 meshes.)
TEST(TensionRayDecision, ALipBesideANotchLeavesTheStartToItsTip) {
  Material paper;
  const MembraneParams membrane = membrane_params(paper);
  const TensionRayDecisionParams params;
  Sheet s = slit_grid(0.2, 0.15, 20, 30, {{10, 15}});
  for (Vec3& x : s.verts.x) x.y() *= 1.01;
  hold(s, Vec2(0.09, 0), Vec2::Zero(), 1.0, true);
  hold(s, Vec2(0.11, 0), Vec2::Zero(), 1.0, false);
  const int32_t lip = vertex_at(s, Vec2(0.1, 0.06), Vec2(-1, 0));
  ASSERT_GE(lip, 0);
  TensionRayDecisionScratch scratch;
  const PropagationDecision d = decide_edge_start(s, lip, 1e3, propagation(), membrane, params, scratch);
  bool straight = true;
  const double excess = start_wrap_excess(s, scratch.result, scratch.loads, scratch, &straight);
  EXPECT_GT(d.energy_release, 10 * 1e3) << "the lip is taut";
  const double leg = std::hypot(0.01, 0.075);
  EXPECT_NEAR(excess, std::hypot(0.01, 0.06) + 0.015 + leg - 2 * leg, 1e-9) << "on the load's path";
  EXPECT_LT(excess, params.start_wrap);
  EXPECT_FALSE(straight) << "which bends at the slit's tip";
  EXPECT_FALSE(d.griffith);
  const int32_t tip = vertex_at(s, Vec2(0.1, 0.075));
  EXPECT_TRUE(decide_by_tension_rays(s, tip, 1e3, true, propagation(), membrane, params, scratch).propagate);
}
