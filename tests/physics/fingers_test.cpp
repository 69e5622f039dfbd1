// Finger targets: linear and smooth key interpolation held outside the keys, and hands moving fingers rigidly
// (rotation about the initial centroid, then translation) — distances between a hand's fingers stay.
#include "systems/physics/fingers.hpp"

#include "tests/test_meshes.hpp"

#include <gtest/gtest.h>

#include <numbers>

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

// "smooth" keys (systems/physics/fingers.cpp): between two keys alone the cubic that starts and ends at
// rest is the smoothstep 3a² − 2a³; it passes through every key, its velocity (central differences) is
// zero at the first and last key and continuous at the others, and equals the Fritsch–Butland slope there.
TEST(Fingers, SmoothKeysStartAndEndAtRestAndKeepTheirVelocity) {
  Finger f;
  f.interpolation = KeyInterpolation::smooth;
  f.keys = {FingerKey{1.0, Vec3(0, 0, 0)}, FingerKey{3.0, Vec3(2, -4, 1)}};
  for (const double a : {0.1, 0.25, 0.5, 0.9}) {
    const double s = 3 * a * a - 2 * a * a * a;
    EXPECT_TRUE(finger_key_position(f, 1.0 + 2 * a).isApprox(s * Vec3(2, -4, 1), 1e-14)) << a;
  }
  // Keys at 0, 1, 3 s with secants 1 and 0.5 m/s in x: slope 3 (h0 + h1) / ((2 h1 + h0) / d0 + (h1 + 2 h0) / d1)
  // = 9 / (5 + 8) m/s at the middle key.
  f.keys = {FingerKey{0.0, Vec3(0, 0, 0)}, FingerKey{1.0, Vec3(1, 0, 0)}, FingerKey{3.0, Vec3(2, 0, 0)}};
  const double h = 1e-6;
  auto velocity = [&](double t) -> Vec3 { return (finger_key_position(f, t + h) - finger_key_position(f, t - h)) / (2 * h); };
  for (const FingerKey& k : f.keys) EXPECT_EQ(finger_key_position(f, k.t), k.position);
  EXPECT_NEAR(velocity(0.0 + h).norm(), 0, 1e-5);  // one-sided: held before the first key
  EXPECT_NEAR(velocity(3.0 - h).norm(), 0, 1e-5);
  const double left = (finger_key_position(f, 1.0).x() - finger_key_position(f, 1.0 - h).x()) / h;
  const double right = (finger_key_position(f, 1.0 + h).x() - finger_key_position(f, 1.0).x()) / h;
  EXPECT_NEAR(left, 9.0 / 13.0, 1e-5);
  EXPECT_NEAR(right, 9.0 / 13.0, 1e-5);
}

// Monotone: keys that rise, hold and come back never overshoot. Between two equal keys the finger holds
// exactly, and at the top it stays within the keys' range, where a spline through the keys (Catmull–Rom)
// would swing past them.
TEST(Fingers, SmoothKeysNeverLeaveTheRangeOfTheirInterval) {
  Finger f;
  f.interpolation = KeyInterpolation::smooth;
  f.keys = {FingerKey{0.0, Vec3(0, 0, 0)}, FingerKey{0.5, Vec3(0.03, 0, 0.01)}, FingerKey{1.0, Vec3(0.035, 0, 0.01)},
            FingerKey{2.0, Vec3(0.035, 0, 0.01)}, FingerKey{2.2, Vec3(0, 0, 0.05)}, FingerKey{3.0, Vec3(0, 0, 0)}};
  for (double t = 0; t <= 3.0; t += 1e-3) {
    size_t i = 1;
    while (i + 1 < f.keys.size() && t >= f.keys[i].t) ++i;
    const Vec3 p = finger_key_position(f, t);
    const Vec3 lo = f.keys[i - 1].position.cwiseMin(f.keys[i].position);
    const Vec3 hi = f.keys[i - 1].position.cwiseMax(f.keys[i].position);
    EXPECT_TRUE((p.array() >= lo.array() - 1e-15).all() && (p.array() <= hi.array() + 1e-15).all())
        << "t " << t << ": " << p.transpose();
    if (t >= 1.0 && t <= 2.0) {
      EXPECT_EQ(p, Vec3(0.035, 0, 0.01)) << t;
    }
  }
}

// A smooth hand eases its translation and its angle alike, and the linear hand is as before: at a key
// both are exact, between them the smooth one has moved less at the start (it starts at rest).
TEST(Fingers, SmoothHandEasesTranslationAndAngle) {
  Hand h;
  h.centroid = Vec3::Zero();
  h.keys = {HandKey{0, Vec3::Zero(), 0, Vec3(0, 0, 1)}, HandKey{1, Vec3(0.1, 0, 0), 90, Vec3(0, 0, 1)}};
  const Vec3 q(0.02, 0, 0);
  Hand smooth = h;
  smooth.interpolation = KeyInterpolation::smooth;
  EXPECT_TRUE(apply_hand_motion(smooth, 1.0, q).isApprox(apply_hand_motion(h, 1.0, q), 1e-15));
  EXPECT_TRUE(apply_hand_motion(h, 0.1, q).isApprox(Vec3(0.01, 0, 0) + hand_rotation(h, 0.1) * q, 1e-15));
  const double s = 3 * 0.01 - 2 * 0.001;  // smoothstep at a = 0.1
  EXPECT_TRUE(apply_hand_motion(smooth, 0.1, q).isApprox(Vec3(0.1 * s, 0, 0) + hand_rotation(smooth, 0.1) * q, 1e-14));
  EXPECT_NEAR(std::acos(hand_rotation(smooth, 0.1)(0, 0)), s * std::numbers::pi / 2, 1e-12);
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

// The pinch's disc in the pattern (Triangles::pinched): the pinched fractions weighted by the triangles'
// areas add up to the disc's area, π r², when it lies inside the sheet, on a coarse mesh (the disc inside
// one fan) and a fine one (the disc over several rings); nothing farther than r is pinched, every triangle
// of the finger's fan is, and a pad's larger radius counts instead.
TEST(Fingers, PinchedFractionsCoverTheFingertipsDisc) {
  for (const int n : {4, 40}) {
    Sheet s = test::grid_sheet(0.1, 0.1, n, n, 0.3, 5);
    Finger f;
    for (int32_t v = 0; v < s.verts.size(); ++v)  // the vertex nearest the middle (the grid is jittered)
      if (f.vertex < 0 || (s.verts.rest[v] - Vec2(0.05, 0.05)).norm() < (s.verts.rest[f.vertex] - Vec2(0.05, 0.05)).norm())
        f.vertex = v;
    const Vec2 centre = s.verts.rest[f.vertex];
    for (const double pad : {0.0, 0.012}) {
      f.pad_radius = pad;
      const double r = std::max(kFingertipRadius, pad);
      std::vector<double> pinched;
      mark_pinched_triangles({f}, s.verts.rest, s.tris.tri, s.topo, kFingertipRadius, pinched);
      ASSERT_EQ(pinched.size(), static_cast<size_t>(s.tris.size()));
      double area = 0;
      for (int32_t t = 0; t < s.tris.size(); ++t) {
        area += pinched[t] * s.tris.rest_area[t];
        double nearest = 1e9;
        for (const int32_t c : s.tris.tri[t]) nearest = std::min(nearest, (s.verts.rest[c] - centre).norm());
        if (nearest > r + 0.1 / n * 1.5) {
          EXPECT_EQ(pinched[t], 0.0) << n << " " << t;
        }
      }
      EXPECT_NEAR(area, std::numbers::pi * r * r, 1e-9 * std::numbers::pi * r * r) << n << " pad " << pad;
      for (const int32_t t : s.topo.fan(f.vertex)) EXPECT_GT(pinched[t], 0.0) << n;
    }
  }
  // No finger holding: nothing pinched.
  Sheet s = test::grid_sheet(0.1, 0.1, 4, 4);
  std::vector<double> pinched;
  mark_pinched_triangles({Finger{}}, s.verts.rest, s.tris.tri, s.topo, kFingertipRadius, pinched);
  for (const double p : pinched) EXPECT_EQ(p, 0.0);
}
