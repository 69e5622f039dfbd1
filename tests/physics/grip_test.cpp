// Fingers that hold like fingers (systems/physics/grip.hpp): hard up to the grip, then the paper slides
// through the pinch; checked on hand-made vertex states against the quasi-static balance.
#include "systems/physics/grip.hpp"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <numbers>

using namespace pt;

namespace {

Vertices two_vertices() {
  Vertices v;
  v.resize(2);
  v.mass = {1e-3, 1e-3};
  v.x[1] = Vec3(0.1, 0, 0);
  return v;
}

Finger finger_on(int32_t vertex, double grip) {
  Finger f;
  f.vertex = vertex;
  f.grip = grip;
  return f;
}

}  // namespace

TEST(Grip, ReactionBalancesTheSheetAndGravity) {
  Vertices v = two_vertices();
  v.force[1] = Vec3(2, 0, 0);
  const Vec3 g(0, 0, -9.81);
  EXPECT_TRUE(held_reaction(v, g, 1).isApprox(Vec3(-2, 0, 1e-3 * 9.81)));
}

TEST(Grip, HoldsBelowTheGripAndSlipsAbove) {
  Vertices v = two_vertices();
  std::vector<Finger> fingers{finger_on(0, 15), finger_on(1, 15)};
  v.force[0] = Vec3(10, 0, 0);  // needs 10 N: held
  v.force[1] = Vec3(0, 20, 0);  // needs 20 N: more than the pinch holds
  EXPECT_TRUE(check_grip(v, Vec3::Zero(), fingers));
  EXPECT_FALSE(fingers[0].slipping);
  EXPECT_EQ(fingers[0].slips, 0);
  EXPECT_NEAR(fingers[0].reaction.norm(), 10, 1e-12);
  EXPECT_NEAR(fingers[0].max_force, 10, 1e-12);
  EXPECT_TRUE(fingers[1].slipping);
  EXPECT_EQ(fingers[1].slips, 1);
  // The reading at which the paper starts to slide is the grip's (it holds no more).
  EXPECT_TRUE(fingers[1].reaction.isApprox(Vec3(0, -15, 0)));
  EXPECT_NEAR(fingers[1].max_force, 15, 1e-12);
  // A slipping finger is not checked again until it holds again.
  EXPECT_FALSE(check_grip(v, Vec3::Zero(), fingers));
  EXPECT_EQ(fingers[1].slips, 1);
}

TEST(Grip, RegripsWhereThePaperIsOrLetsGoPastItsReach) {
  Vertices v = two_vertices();
  std::vector<Finger> fingers{finger_on(0, 15), finger_on(1, 15)};
  fingers[0].slipping = fingers[1].slipping = true;
  // Finger 0's point is 5 mm from its vertex: it holds the vertex where it is, 5 mm off.
  // Finger 1's is 3 cm away: the paper has slid out of the pinch.
  const std::vector<Vec3> targets{Vec3(0.005, 0, 0), Vec3(0.1, 0.03, 0)};
  const std::vector<Mat3> rotations(2, Mat3::Identity());
  EXPECT_TRUE(regrip_slipping_fingers(v, targets, rotations, fingers));
  EXPECT_FALSE(fingers[0].slipping);
  EXPECT_TRUE(fingers[0].hold_offset.isApprox(Vec3(-0.005, 0, 0)));
  EXPECT_EQ(fingers[0].vertex, 0);
  EXPECT_FALSE(fingers[0].let_go);
  EXPECT_EQ(fingers[1].vertex, -1);
  EXPECT_TRUE(fingers[1].released);
  EXPECT_TRUE(fingers[1].let_go);
}

// A transient state (the relaxation substep after a cut) gives the tearing step its reactions, but the
// fingers never held it: neither a slip nor max_force.
TEST(Grip, TransientReactionsAreReadButNotHeld) {
  Vertices v = two_vertices();
  std::vector<Finger> fingers{finger_on(0, 15)};
  v.force[0] = Vec3(3, 0, 0);
  read_reactions(v, Vec3::Zero(), fingers);
  EXPECT_NEAR(fingers[0].max_force, 3, 1e-12);
  v.force[0] = Vec3(0, 40, 0);  // past the grip
  read_transient_reactions(v, Vec3::Zero(), fingers);
  EXPECT_TRUE(fingers[0].reaction.isApprox(Vec3(0, -40, 0)));
  EXPECT_NEAR(fingers[0].max_force, 3, 1e-12);
  EXPECT_FALSE(fingers[0].slipping);
  EXPECT_EQ(fingers[0].slips, 0);
}

// A pad (systems/physics/fingers.hpp) is one pinch: its force is what its vertices' balances sum to, and
// that sum is what the grip holds. Two vertices each pulled by 9 N hold 18 N: past a 15 N grip together.
// A pinch that holds again takes its pad's offsets where the paper is, in the hand's frame.
TEST(Grip, APadIsOnePinch) {
  Vertices v = two_vertices();
  v.force[0] = Vec3(0, -9, 0);
  v.force[1] = Vec3(0, -9, 0);
  Finger f = finger_on(0, 15);
  f.pad = {1};
  f.pad_offset = {Vec3(0.1, 0, 0)};
  EXPECT_TRUE(finger_reaction(v, Vec3::Zero(), f).isApprox(Vec3(0, 18, 0)));
  std::vector<Finger> fingers{f};
  EXPECT_TRUE(check_grip(v, Vec3::Zero(), fingers));
  EXPECT_TRUE(fingers[0].slipping);
  // Holding again after a quarter turn about z: the pad's vertex, +x of the finger's, is −y in the hand's frame.
  const Mat3 quarter = Eigen::AngleAxisd(std::numbers::pi / 2, Vec3::UnitZ()).toRotationMatrix();
  EXPECT_FALSE(regrip_slipping_fingers(v, {Vec3::Zero()}, {quarter}, fingers));
  EXPECT_TRUE(fingers[0].pad_offset[0].isApprox(Vec3(0, -0.1, 0), 1e-12));
  EXPECT_TRUE((quarter * fingers[0].pad_offset[0]).isApprox(v.x[1] - v.x[0], 1e-12));
}
