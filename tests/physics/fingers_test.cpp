// Finger targets: linear key interpolation held outside the keys, and hands moving fingers rigidly
// (rotation about the initial centroid, then translation) — distances between a hand's fingers stay.
#include "systems/physics/fingers.hpp"

#include <gtest/gtest.h>

using namespace pt;

TEST(Fingers, KeysInterpolateAndHold) {
  Finger f;
  f.start = Vec3(1, 2, 0);
  EXPECT_EQ(finger_key_position(f, 5.0), f.start);
  f.keys = {FingerKey{1.0, Vec3(0, 0, 0)}, FingerKey{3.0, Vec3(2, 0, 4)}};
  EXPECT_EQ(finger_key_position(f, 0.0), Vec3(0, 0, 0));
  EXPECT_TRUE(finger_key_position(f, 2.0).isApprox(Vec3(1, 0, 2)));
  EXPECT_EQ(finger_key_position(f, 9.0), Vec3(2, 0, 4));
}

TEST(Fingers, HandMovesItsFingersRigidly) {
  std::vector<Finger> fingers(2);
  fingers[0].start = Vec3(0, 0, 0);
  fingers[1].start = Vec3(0.02, 0, 0);
  fingers[0].hand = fingers[1].hand = 0;
  Hand h;
  h.fingers = {0, 1};
  h.centroid = Vec3(0.01, 0, 0);
  h.keys = {HandKey{0, Vec3::Zero(), 0, Vec3(0, 1, 0)}, HandKey{1, Vec3(0, 0, 0.05), 90, Vec3(0, 1, 0)}};
  std::vector<Hand> hands{h};
  update_finger_targets(1.0, hands, fingers);
  EXPECT_NEAR((fingers[0].target - fingers[1].target).norm(), 0.02, 1e-12);
  // 90° about +y around the centroid turns the +x offset into −z; then +z translation.
  EXPECT_TRUE(fingers[1].target.isApprox(Vec3(0.01, 0, 0.05 - 0.01), 1e-12));
  update_finger_targets(0.5, hands, fingers);
  EXPECT_NEAR((fingers[0].target - fingers[1].target).norm(), 0.02, 1e-12);
  EXPECT_NEAR(fingers[0].target.z() + fingers[1].target.z(), 2 * 0.025, 1e-12);
}

// Issue 27: an axis whose norm overflows (1e200² > the largest double) or underflows is still a direction:
// the hand turns about it (before: the axis became zero and the hand was scaled, not rotated).
TEST(Fingers, HandAxisOfAnySizeRotates) {
  Finger f;
  f.start = Vec3(0.02, 0, 0);
  f.hand = 0;
  Hand h;
  h.fingers = {0};
  h.centroid = Vec3::Zero();
  const Vec3 expected = [] {
    Hand unit;
    unit.keys = {HandKey{0, Vec3::Zero(), 90, Vec3(1, 1, 0)}};
    return apply_hand_motion(unit, 0, Vec3(0.02, 0, 0));
  }();
  EXPECT_NEAR(expected.norm(), 0.02, 1e-15);  // a rotation keeps the distance to the centroid
  for (const double scale : {1e200, 1e-200, 1e308, 4.9e-324}) {
    h.keys = {HandKey{0, Vec3::Zero(), 90, Vec3(scale, scale, 0)}};
    std::vector<Hand> hands{h};
    std::vector<Finger> fingers{f};
    update_finger_targets(0, hands, fingers);
    EXPECT_TRUE(fingers[0].target.allFinite()) << scale;
    EXPECT_NEAR((fingers[0].target - expected).norm(), 0, 1e-15) << scale << ": " << fingers[0].target.transpose();
  }
}
