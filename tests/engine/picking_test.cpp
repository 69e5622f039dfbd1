// Picking (issue 7): rays against a known deformed mesh hit the expected triangle at the expected
// barycentric and pattern point; misses report nothing; position updates refit, topology changes rebuild.
#include "engine/picking.hpp"
#include "engine/scenario.hpp"
#include "engine/simulation.hpp"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>

namespace pt {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A grid of nx × ny cells over [0, 0.2] × [0, 0.1] (pattern), bent along u: z = 0.03 sin(π u / 0.2).
double bend(double u) { return 0.03 * std::sin(kPi * u / 0.2); }

Sheet bent_grid(int nx, int ny) {
  Sheet s;
  const double lx = 0.2, ly = 0.1;
  s.verts.resize((nx + 1) * (ny + 1));
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      const int id = j * (nx + 1) + i;
      const Vec2 r(lx * i / nx, ly * j / ny);
      s.verts.rest[id] = r;
      s.verts.x[id] = Vec3(r.x(), r.y(), bend(r.x()));
    }
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int a = j * (nx + 1) + i, b = a + 1, c = a + nx + 1, d = c + 1;
      s.tris.tri.push_back({a, b, d});  // counter-clockwise in the pattern
      s.tris.tri.push_back({a, d, c});
    }
  s.tris.resize(static_cast<int32_t>(s.tris.tri.size()));
  s.topology_version = 1;
  return s;
}

Vec3 at(const Sheet& s, int t, double u, double v) {
  const Tri& c = s.tris.tri[t];
  return (1 - u - v) * s.verts.x[c[0]] + u * s.verts.x[c[1]] + v * s.verts.x[c[2]];
}
Vec2 pattern_at(const Sheet& s, int t, double u, double v) {
  const Tri& c = s.tris.tri[t];
  return (1 - u - v) * s.verts.rest[c[0]] + u * s.verts.rest[c[1]] + v * s.verts.rest[c[2]];
}

TEST(Picking, HitsExpectedTriangleAndBarycentricFromAbove) {
  const Sheet s = bent_grid(20, 10);
  Picker picker;
  picker.update(s);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> w(0.05, 0.9);
  std::uniform_int_distribution<int> tri(0, s.tris.size() - 1);
  int checked = 0;
  for (int k = 0; k < 200; ++k) {
    const int t = tri(rng);
    double u = w(rng), v = w(rng);
    if (u + v > 0.95) {
      u *= 0.5;
      v *= 0.5;
    }
    const Vec3 p = at(s, t, u, v);
    // From above the bend, slightly oblique; the bump is shallow so nothing else is in the way.
    const Vec3 origin = p + Vec3(0.003, -0.002, 0.25);
    const Vec3 dir = (p - origin).normalized();
    const auto hit = picker.pick(origin, dir);
    ASSERT_TRUE(hit.has_value()) << "triangle " << t;
    EXPECT_EQ(hit->triangle, t);
    EXPECT_NEAR(hit->u, u, 1e-6);
    EXPECT_NEAR(hit->v, v, 1e-6);
    EXPECT_NEAR((hit->point - p).norm(), 0.0, 1e-6);
    EXPECT_NEAR((hit->uv - pattern_at(s, t, u, v)).norm(), 0.0, 1e-6);
    EXPECT_NEAR(hit->t, (p - origin).norm(), 1e-6);
    ++checked;
  }
  EXPECT_EQ(checked, 200);
}

TEST(Picking, BothSidesAndNearestHit) {
  const Sheet s = bent_grid(20, 10);
  Picker picker;
  picker.update(s);
  // From below (the back side), straight up through a known interior point.
  const int t = 2 * (5 * 20 + 7);  // cell (7, 5), first triangle
  const Vec3 p = at(s, t, 0.3, 0.2);
  const auto below = picker.pick(p - Vec3(0, 0, 0.5), Vec3(0, 0, 1));
  ASSERT_TRUE(below.has_value());
  EXPECT_EQ(below->triangle, t);
  EXPECT_NEAR(below->u, 0.3, 1e-6);
  EXPECT_NEAR(below->v, 0.2, 1e-6);
  // A grazing ray along u at height 0.02 crosses the bump twice: the first crossing is reported.
  const auto graze = picker.pick(Vec3(-0.05, 0.055, 0.02), Vec3(1, 0, 0));
  ASSERT_TRUE(graze.has_value());
  EXPECT_NEAR(bend(graze->point.x()), 0.02, 1e-3);  // piecewise linear mesh vs. sine
  EXPECT_LT(graze->point.x(), 0.1);
  EXPECT_NEAR(graze->uv.y(), 0.055, 1e-9);
}

TEST(Picking, MissesReturnNothing) {
  const Sheet s = bent_grid(20, 10);
  Picker picker;
  picker.update(s);
  EXPECT_FALSE(picker.pick(Vec3(0.1, 0.05, 0.5), Vec3(0, 0, 1)).has_value());     // pointing away
  EXPECT_FALSE(picker.pick(Vec3(0.3, 0.05, 0.5), Vec3(0, 0, -1)).has_value());    // beside the sheet
  EXPECT_FALSE(picker.pick(Vec3(0.1, 0.05, 0.5), Vec3(0, 0, -1), 0, 0.1).has_value());  // tfar too short
  EXPECT_FALSE(picker.pick(Vec3(0.1, 0.05, 0.5), Vec3(0, 0, 0)).has_value());     // no direction
  Picker empty;
  EXPECT_FALSE(empty.pick(Vec3(0.1, 0.05, 0.5), Vec3(0, 0, -1)).has_value());     // nothing loaded
}

TEST(Picking, RefitsOnMotionRebuildsOnTopology) {
  Sheet s = bent_grid(10, 5);
  Picker picker;
  picker.update(s);
  EXPECT_EQ(picker.rebuilds(), 1);
  // Lift the whole sheet by 1 cm: same topology, refit only; the hit moves with it.
  for (Vec3& x : s.verts.x) x.z() += 0.01;
  picker.update(s);
  EXPECT_EQ(picker.rebuilds(), 1);
  EXPECT_EQ(picker.refits(), 1);
  const int t = 13;
  const Vec3 p = at(s, t, 0.25, 0.25);
  auto hit = picker.pick(p + Vec3(0, 0, 1), Vec3(0, 0, -1));
  ASSERT_TRUE(hit.has_value());
  EXPECT_EQ(hit->triangle, t);
  EXPECT_NEAR(hit->point.z(), p.z(), 1e-9);
  // Drop the last cell's two triangles: a topology change rebuilds, and that cell now misses.
  const Vec3 last = at(s, s.tris.size() - 1, 0.3, 0.3);
  s.tris.tri.resize(s.tris.tri.size() - 2);
  s.tris.resize(static_cast<int32_t>(s.tris.tri.size()));
  ++s.topology_version;
  picker.update(s);
  EXPECT_EQ(picker.rebuilds(), 2);
  EXPECT_FALSE(picker.pick(last + Vec3(0, 0, 1), Vec3(0, 0, -1)).has_value());
}

// Pick time on a ~1 000-triangle sheet deformed by a few frames of a tearing scenario.
TEST(Picking, PickTimeOnThousandTriangleSheet) {
  Scenario sc = load_scenario(std::string(PT_SOURCE_DIR) + "/scenarios/fig14-straight.json");
  sc.triangles = 1000;
  Simulation sim(sc);
  for (int f = 0; f < 10; ++f) sim.step();
  const Sheet& s = sim.sheet();
  Picker picker;
  using Clock = std::chrono::steady_clock;
  auto t0 = Clock::now();
  picker.update(s);
  const double build_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  t0 = Clock::now();
  constexpr int kRefits = 200;
  for (int k = 0; k < kRefits; ++k) picker.update(s);
  const double refit_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count() / kRefits;

  std::mt19937 rng(3);
  std::uniform_real_distribution<double> ux(0.0, 0.148), uy(0.0, 0.21), jitter(-0.05, 0.05);
  constexpr int kRays = 20000;
  int hits = 0;
  t0 = Clock::now();
  for (int k = 0; k < kRays; ++k) {
    const Vec3 target(ux(rng), uy(rng), 0.0);
    const Vec3 origin(0.074 + jitter(rng), 0.1 + jitter(rng), 0.4);
    if (picker.pick(origin, target - origin)) ++hits;
  }
  const double pick_us = std::chrono::duration<double, std::micro>(Clock::now() - t0).count() / kRays;
  std::printf("[ picking ] %d triangles: build %.3f ms, refit %.3f ms, pick %.3f us (%d/%d hits)\n", s.tris.size(),
              build_ms, refit_ms, pick_us, hits, kRays);
  EXPECT_GT(hits, kRays / 2);
  EXPECT_LT(pick_us, 100.0);  // issue 7: a pick ≤ 0.1 ms
}

}  // namespace
}  // namespace pt
