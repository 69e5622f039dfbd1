// Potential tearing points (paper §4.1) and fracture energy (eq. 3; docs/tearing.md
// "Potential tearing points and fracture energy") on a hand-built notched sheet: which boundary vertices
// are listed, in which order, of which kind, with Ef = c · T_fiber · d.
#include "systems/tearing/candidates.hpp"
#include "systems/common/topology.hpp"

#include <gtest/gtest.h>

#include <algorithm>

using namespace pt;

namespace {

// A 20 cm x 10 cm rectangle with a V notch cut from the top edge down to its apex, vertex 5, and one
// interior vertex, 8 (units: 5 cm).
//
//   7 ------- 6   4 ------- 3
//   |          \ /          |
//   |           5           |
//   |           8           |
//   0 --------- 1 --------- 2
Sheet notched_sheet() {
  Sheet s;
  s.verts.resize(9);
  const double u = 0.05;
  s.verts.rest = {Vec2(0, 0),     Vec2(2, 0),  Vec2(4, 0),     Vec2(4, 2),  Vec2(2.2, 2),
                  Vec2(2, 1),     Vec2(1.8, 2), Vec2(0, 2),    Vec2(2, 0.5)};
  for (Vec2& r : s.verts.rest) r *= u;
  for (int32_t v = 0; v < 9; ++v) s.verts.x[v] = Vec3(s.verts.rest[v].x(), s.verts.rest[v].y(), 0);
  s.tris.resize(8);
  s.tris.tri = {Tri{0, 1, 8}, Tri{0, 8, 5}, Tri{0, 5, 6}, Tri{0, 6, 7},
                Tri{1, 2, 8}, Tri{2, 5, 8}, Tri{2, 3, 5}, Tri{3, 4, 5}};
  s.material.fracture_c = 1.2e4;
  s.material.tip_damage = 0.3;
  refresh_after_topology_change(s);
  return s;
}

FiberField fiber_field() {
  FiberField f;
  f.seed = 7;
  f.origin = Vec2::Zero();
  f.pixel_size = 1e-4;
  return f;
}

// The engine's call (engine/simulation.cpp): over the topology's boundary vertices, with a fresh T_fiber
// cache, so every value is sampled anew. Tips whose tear is not in `tears` take their kind from their flags.
void list_candidates(const Sheet& s, const std::vector<Tip>& tips, const std::vector<Tear>& tears,
                     const Material& material, const FiberField& fiber, std::vector<Candidate>& out) {
  FiberSampleCache cache;
  find_candidates(s.verts, s.topo.boundary_vertices, tips, s.fingers, tears, material, fiber, out, cache);
}

std::vector<int32_t> vertices_of(const std::vector<Candidate>& c) {
  std::vector<int32_t> v;
  for (const Candidate& k : c) v.push_back(k.vertex);
  return v;
}

// Eq. 3 against the fiber field itself: Ef / (c · d) is T_fiber at the vertex lifted onto
// [fiber_floor, 1] (material.fiber_floor = 0 is the paper's eq. 3 exactly).
void expect_fracture_energy(const Sheet& s, const FiberField& fiber, const Candidate& c, double d) {
  const double t = c.fracture_energy / (s.material.fracture_c * d);
  const double floor = s.material.fiber_floor;
  EXPECT_GE(t, floor) << c.vertex;
  EXPECT_LE(t, 1.0) << c.vertex;
  EXPECT_NEAR(t, floor + (1 - floor) * fiber_sample(fiber, s.verts.rest[c.vertex]), 1e-14) << c.vertex;
}

}  // namespace

TEST(Candidates, NotchApexIsTheOnlyInwardPoint) {
  Sheet s = notched_sheet();
  ASSERT_EQ(check_mesh_invariants(s, 7.8 * 0.05 * 0.05), "");
  const FiberField fiber = fiber_field();
  std::vector<Candidate> out;
  list_candidates(s, s.tips, {}, s.material, fiber, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].vertex, 5);
  EXPECT_EQ(out[0].kind, StartKind::Inward);
  EXPECT_EQ(out[0].tear, -1);
  expect_fracture_energy(s, fiber, out[0], 1.0);
  EXPECT_GT(out[0].fracture_energy, 0.0);
  EXPECT_LT(out[0].fracture_energy, s.material.fracture_c);
}

// Finger and junction points on the boundary join the inward apex, by vertex id; a vertex of several
// kinds takes the first of finger > junction > inward; interior vertices are never candidates.
TEST(Candidates, KindsAndOrderOfBoundaryPoints) {
  Sheet s = notched_sheet();
  s.verts.flags[7] |= kFinger;
  s.verts.flags[1] |= kJunction;
  s.verts.flags[3] |= kJunction | kFinger;
  s.verts.flags[5] |= kJunction;              // the apex is also a junction
  s.verts.flags[8] |= kFinger | kJunction;    // interior: not a tearing point
  Finger held;
  held.vertex = 2;                            // held by a finger, flag not refreshed yet
  s.fingers.push_back(held);
  const FiberField fiber = fiber_field();
  std::vector<Candidate> out;
  list_candidates(s, s.tips, {}, s.material, fiber, out);
  EXPECT_EQ(vertices_of(out), (std::vector<int32_t>{1, 2, 3, 5, 7}));
  ASSERT_EQ(out.size(), 5u);
  EXPECT_EQ(out[0].kind, StartKind::Junction);
  EXPECT_EQ(out[1].kind, StartKind::Finger);
  EXPECT_EQ(out[2].kind, StartKind::Finger);
  EXPECT_EQ(out[3].kind, StartKind::Junction);
  EXPECT_EQ(out[4].kind, StartKind::Finger);
  for (const Candidate& c : out) {
    EXPECT_EQ(c.tear, -1);
    expect_fracture_energy(s, fiber, c, 1.0);
  }
}

// Active tips come first, by tear id, whatever the order of `tips`; their Ef carries the damage D; the
// rest follow by vertex id without repeating a tip.
TEST(Candidates, ActiveTipsFirstWithDamage) {
  Sheet s = notched_sheet();
  s.verts.flags[7] |= kFinger;
  s.tips = {Tip{5, 2, Vec2(0, -1)}, Tip{6, 0, Vec2(1, 0)}};
  s.tears.resize(3);
  for (int32_t i = 0; i < 3; ++i) s.tears[i].id = i;
  s.tears[0].start_kind = StartKind::Finger;
  s.tears[2].start_kind = StartKind::Junction;
  const FiberField fiber = fiber_field();

  std::vector<Candidate> out;
  list_candidates(s, s.tips, {}, s.material, fiber, out);
  EXPECT_EQ(vertices_of(out), (std::vector<int32_t>{6, 5, 7}));
  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ(out[0].tear, 0);
  EXPECT_EQ(out[1].tear, 2);
  EXPECT_EQ(out[2].tear, -1);
  // With no tears given a tip's kind comes from its flags: 6 has none (a tip is an inward point), 5 is inward.
  EXPECT_EQ(out[0].kind, StartKind::Inward);
  EXPECT_EQ(out[1].kind, StartKind::Inward);
  EXPECT_EQ(out[2].kind, StartKind::Finger);
  expect_fracture_energy(s, fiber, out[0], s.material.tip_damage);
  expect_fracture_energy(s, fiber, out[1], s.material.tip_damage);
  expect_fracture_energy(s, fiber, out[2], 1.0);
  const double floor = s.material.fiber_floor;
  EXPECT_NEAR(out[0].fracture_energy,
              s.material.fracture_c * (floor + (1 - floor) * fiber_sample(fiber, s.verts.rest[6])) *
                  s.material.tip_damage,
              1e-9);

  // With the tears, a tip's kind is its tear's start kind.
  std::vector<Candidate> with_tears;
  list_candidates(s, s.tips, s.tears, s.material, fiber, with_tears);
  ASSERT_EQ(with_tears.size(), 3u);
  EXPECT_EQ(with_tears[0].kind, StartKind::Finger);
  EXPECT_EQ(with_tears[1].kind, StartKind::Junction);

  // Deterministic: the order of `tips` does not matter, and `out` is replaced, not appended to.
  std::vector<Tip> reversed(s.tips.rbegin(), s.tips.rend());
  std::vector<Candidate> again = out;
  list_candidates(s, reversed, {}, s.material, fiber, again);
  ASSERT_EQ(again.size(), out.size());
  for (size_t i = 0; i < out.size(); ++i) {
    EXPECT_EQ(again[i].vertex, out[i].vertex);
    EXPECT_EQ(again[i].fracture_energy, out[i].fracture_energy);
  }
}

// The per-vertex T_fiber cache kept between calls gives bit for bit the Ef of a fresh one, and follows a
// vertex that moved in the pattern or was renumbered (remeshing swaps vertices) instead of returning a
// stale value.
TEST(Candidates, FiberCacheMatchesUncachedAndFollowsMovedVertices) {
  Sheet s = notched_sheet();
  s.tips = {Tip{5, 0, Vec2::Zero()}};
  const FiberField fiber = fiber_field();
  FiberSampleCache cache;
  for (int round = 0; round < 3; ++round) {
    if (round == 1) std::swap(s.verts.rest[5], s.verts.rest[6]);            // a renumbering
    if (round == 2) s.verts.rest[6] += Vec2(0.0031, -0.0017);              // a vertex at a new point
    std::vector<Candidate> cached, plain;
    find_candidates(s.verts, s.topo.boundary_vertices, s.tips, s.fingers, s.tears, s.material, fiber, cached, cache);
    list_candidates(s, s.tips, s.tears, s.material, fiber, plain);
    ASSERT_EQ(cached.size(), plain.size());
    for (size_t i = 0; i < plain.size(); ++i) {
      EXPECT_EQ(cached[i].vertex, plain[i].vertex);
      EXPECT_EQ(cached[i].fracture_energy, plain[i].fracture_energy) << "round " << round << " candidate " << i;
    }
  }
}

// Ef scales with c and, at a tip, with D (eq. 3); D = 0 makes a tip free to run.
TEST(Candidates, FractureEnergyScalesWithMaterial) {
  Sheet s = notched_sheet();
  s.tips = {Tip{5, 0, Vec2::Zero()}};
  const FiberField fiber = fiber_field();
  std::vector<Candidate> a, b;
  list_candidates(s, s.tips, {}, s.material, fiber, a);
  Material m = s.material;
  m.fracture_c *= 3;
  list_candidates(s, s.tips, {}, m, fiber, b);
  ASSERT_EQ(a.size(), 1u);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_NEAR(b[0].fracture_energy, 3 * a[0].fracture_energy, 1e-12 * b[0].fracture_energy);
  m.tip_damage = 0;
  list_candidates(s, s.tips, {}, m, fiber, b);
  EXPECT_EQ(b[0].fracture_energy, 0.0);
}

// The lips of a tear separate and so always touch two regions: that is the tear, not a junction; a lip
// vertex stays a candidate only as an inward angle or a finger. A fiber floor of 0 is eq. 3 exactly.
TEST(Candidates, LipVerticesAreNotJunctionsAndFloorZeroIsEquationThree) {
  Sheet s;
  s.verts.resize(4);
  s.verts.rest = {Vec2(0, 0), Vec2(1, 0), Vec2(1, 1), Vec2(0, 1)};
  s.tris.resize(2);
  s.tris.tri = {Tri{0, 1, 2}, Tri{0, 2, 3}};
  refresh_after_topology_change(s);
  s.verts.flags[1] |= kJunction;
  s.verts.flags[2] |= kJunction;
  s.verts.tear[2] = 0;  // vertex 2 is on the lip of tear 0
  s.material.fiber_floor = 0;
  FiberField fiber;
  std::vector<Candidate> out;
  list_candidates(s, {}, {}, s.material, fiber, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].vertex, 1);
  EXPECT_EQ(out[0].kind, StartKind::Junction);
  EXPECT_NEAR(out[0].fracture_energy, s.material.fracture_c * fiber_sample(fiber, s.verts.rest[1]), 1e-9);
}
