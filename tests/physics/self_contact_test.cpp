// Self-contact (systems/physics/self_contact.hpp) against independent truths: analytic times of impact,
// the exact intersection count of systems/self_intersection.hpp (after every substep), momentum, and thread
// counts.
#include "systems/physics/self_contact.hpp"
#include "systems/mesh/self_intersection.hpp"
#include "tests/test_meshes.hpp"

#include <gtest/gtest.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>

namespace pt {
namespace {

TEST(SelfContactCcd, VertexMeetsMovingTriangleAtTheAnalyticTime) {
  // The triangle rises from z = 0 to 0.5, the vertex falls from 1 to −1 over it: 1 − 2t = 0.5t at t = 0.4.
  double t = -1;
  const Vec3 up(0, 0, 0.5);
  ASSERT_TRUE(vertex_triangle_ccd(Vec3(0.2, 0.3, 1), Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0.2, 0.3, -1),
                                  up, Vec3(1, 0, 0) + up, Vec3(0, 1, 0) + up, 1e-9, t));
  EXPECT_NEAR(t, 0.4, 1e-9);
  // Beside the triangle it passes its plane and meets nothing.
  EXPECT_FALSE(vertex_triangle_ccd(Vec3(0.8, 0.8, 1), Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0.8, 0.8, -1),
                                   up, Vec3(1, 0, 0) + up, Vec3(0, 1, 0) + up, 1e-9, t));
  // A tilting triangle: corner c rises from 0 to 1 while the vertex at (0.25, 0.5) stays at z = 0.25. The
  // plane's height there is 0.5 t (c's weight 0.5), so t = 0.5.
  ASSERT_TRUE(vertex_triangle_ccd(Vec3(0.25, 0.5, 0.25), Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0),
                                  Vec3(0.25, 0.5, 0.25), Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 1), 1e-9, t));
  EXPECT_NEAR(t, 0.5, 1e-9);
}

TEST(SelfContactCcd, EdgesCrossAtTheAnalyticTime) {
  // Edge x from z = 1 falling at 3 per step onto edge y rising from 0 at 1 per step: 1 − 3t = t at t = 0.25.
  double t = -1;
  ASSERT_TRUE(edge_edge_ccd(Vec3(-1, 0, 1), Vec3(1, 0, 1), Vec3(0, -1, 0), Vec3(0, 1, 0), Vec3(-1, 0, -2),
                            Vec3(1, 0, -2), Vec3(0, -1, 1), Vec3(0, 1, 1), 1e-9, t));
  EXPECT_NEAR(t, 0.25, 1e-9);
  // Shifted past the other's end, they pass.
  EXPECT_FALSE(edge_edge_ccd(Vec3(-1, 2, 1), Vec3(1, 2, 1), Vec3(0, -1, 0), Vec3(0, 1, 0), Vec3(-1, 2, -2),
                             Vec3(1, 2, -2), Vec3(0, -1, 1), Vec3(0, 1, 1), 1e-9, t));
}

// Two jittered grids of n × n cells over 10 cm (tests/test_meshes.hpp's grid_sheet), one at z = 0 and one
// `height` above it, tilted a little.
struct TwoSheets {
  std::vector<Vec3> x, v;
  std::vector<Vec2> rest;
  std::vector<double> inverse_mass;
  std::vector<Tri> tris;
  int32_t upper_first = 0;  // the first vertex of the upper sheet
};

TwoSheets two_sheets(int n, double height, double tilt, uint32_t seed) {
  TwoSheets s;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  const double size = 0.1;
  for (int sheet = 0; sheet < 2; ++sheet) {
    const Sheet grid = test::grid_sheet(size, size, n, n, 0.6, seed + sheet);
    const auto first = static_cast<int32_t>(s.x.size());
    if (sheet == 1) s.upper_first = first;
    for (const Vec2& p : grid.verts.rest) {
      // Different pattern points: the two sheets are not twins of a tear.
      s.rest.push_back(p + Vec2(sheet * 2 * size, 0));
      s.x.push_back(sheet == 0 ? Vec3(p.x(), p.y(), 0) : Vec3(p.x(), p.y(), height + tilt * (p.x() - size / 2)));
      s.v.push_back(Vec3::Zero());
      s.inverse_mass.push_back(1 / (1e-3 * (1 + 0.1 * u(rng))));
    }
    for (const Tri& t : grid.tris.tri) s.tris.push_back({first + t[0], first + t[1], first + t[2]});
  }
  return s;
}

// Free flight of one substep (x += h v) followed by the self-contact pass.
SelfContactStats fly(const SelfContactParams& params, TwoSheets& s, SelfContactBroadPhasePtr& broad) {
  const std::vector<Vec3> x0 = s.x;
  for (size_t i = 0; i < s.x.size(); ++i) s.x[i] += params.dt * s.v[i];
  return resolve_self_contact(params, s.tris, s.rest, x0, s.inverse_mass, broad, s.x, s.v);
}

TEST(SelfContact, ParallelSheetsApproachingNeverIntersect) {
  for (const double speed : {0.05, 1.0, 5.0}) {  // under the gap per substep, ten gaps, fifty gaps
    TwoSheets s = two_sheets(12, 0.004, 0.02, 7);
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(-0.2, 0.2);
    // Falling unevenly (no forces hold the sheet together, so it wrinkles as it lands) and drifting.
    for (int32_t i = s.upper_first; i < static_cast<int32_t>(s.x.size()); ++i)
      s.v[i] = Vec3(0.01, 0.005, -speed * (1 + u(rng)));
    SelfContactParams params;
    SelfContactBroadPhasePtr broad;
    int64_t contacts = 0;
    for (int step = 0; step < 60; ++step) {
      const SelfContactStats stats = fly(params, s, broad);
      contacts += stats.repulsions + stats.collisions;
      if (std::getenv("PT_SELF_CONTACT_TRACE"))
        std::printf("speed %g step %d: candidates %ld proximities %ld repulsions %ld collisions %ld zones %ld %.2f ms\n",
                    speed, step, long(stats.candidates), long(stats.proximities), long(stats.repulsions),
                    long(stats.collisions), long(stats.zones), stats.ms);
      EXPECT_EQ(stats.unresolved, 0) << "speed " << speed << " step " << step;
      ASSERT_EQ(count_self_intersections(s.x, s.tris).intersecting, 0) << "speed " << speed << " step " << step;
    }
    EXPECT_GT(contacts, 0) << speed;
    // The upper sheet lies on the lower one, not through it: both free, the stack falls on together.
    double upper = 0, lower = 0;
    for (int32_t i = 0; i < static_cast<int32_t>(s.x.size()); ++i) (i < s.upper_first ? lower : upper) += s.x[i].z();
    EXPECT_GT(upper / (s.x.size() - s.upper_first), lower / s.upper_first) << speed;
  }
}

TEST(SelfContact, WithoutItTheSheetsPassThrough) {
  // The measure can fail: the same flight without the pass ends with the sheets through each other.
  TwoSheets s = two_sheets(12, 0.004, 0.02, 7);
  for (int32_t i = s.upper_first; i < static_cast<int32_t>(s.x.size()); ++i) s.v[i] = Vec3(0, 0, -1);
  // One substep takes its middle from 4 mm to 0.7 mm above the lower sheet, its ends 1 mm either side.
  for (size_t i = 0; i < s.x.size(); ++i) s.x[i] += (1.0 / 300) * s.v[i];
  EXPECT_GT(count_self_intersections(s.x, s.tris).intersecting, 0);
}

// The pairs the implicit step keeps apart (self_contact_proximities): every vertex of the upper sheet
// within twice the gap of the lower one pairs with a lower triangle, with the face's normal pointing up
// and its distance to the plane; none pairs with its own sheet (its triangles are neighbours or farther
// than the gap); a vertex beyond the lower sheet's border by less than the gap keeps the face's normal
// (a folded layer's border over the other's), and one farther beside it gets none.
TEST(SelfContactProximities, PairsAreOverTheOtherLayerWithTheFacesNormal) {
  const double gap = 3e-4;
  TwoSheets s = two_sheets(8, 4e-4, 0, 5);
  SelfContactParams params;
  params.gap = gap;
  SelfContactBroadPhasePtr broad;
  std::vector<ProximityPair> pairs;
  self_contact_proximities(params, s.tris, s.rest, s.x, s.x, broad, pairs);
  std::vector<int32_t> paired;
  for (const ProximityPair& q : pairs) {
    const bool upper = q.vertex >= s.upper_first;
    for (const int32_t c : q.triangle) EXPECT_NE(upper, c >= s.upper_first) << "a pair within one sheet";
    const Vec3 on = q.weights[0] * s.x[q.triangle[0]] + q.weights[1] * s.x[q.triangle[1]] + q.weights[2] * s.x[q.triangle[2]];
    EXPECT_NEAR(q.normal.norm(), 1, 1e-12);
    EXPECT_NEAR(q.normal.dot(s.x[q.vertex] - on), q.distance, 1e-12);
    // Over the face, or beside its border by less than the gap: the face's normal and the height above
    // it; farther beside the border (the jittered sheets' borders differ), from the nearest point.
    if (std::abs(q.normal.z()) > 1 - 1e-12) EXPECT_NEAR(q.distance, 4e-4, 1e-12);
    else EXPECT_NEAR((s.x[q.vertex] - on).norm(), q.distance, 1e-12);
    EXPECT_GE(q.distance, 4e-4 - 1e-12);
    EXPECT_EQ(q.normal.z() > 0, upper) << "from the triangle to the vertex";
    if (upper) paired.push_back(q.vertex);
  }
  std::sort(paired.begin(), paired.end());
  paired.erase(std::unique(paired.begin(), paired.end()), paired.end());
  EXPECT_EQ(paired.size(), s.x.size() - s.upper_first) << "every upper vertex is over the lower sheet";
  EXPECT_TRUE(std::is_sorted(pairs.begin(), pairs.end(), [](const ProximityPair& a, const ProximityPair& b) {
    return a.vertex != b.vertex ? a.vertex < b.vertex : a.triangle < b.triangle;
  }));

  // The upper sheet moved 0.1 mm (under the gap) or 1 mm beyond the lower sheet's x = 0 border.
  for (const double beyond : {1e-4, 1e-3}) {
    TwoSheets side = two_sheets(8, 2e-4, 0, 5);
    for (int32_t i = side.upper_first; i < static_cast<int32_t>(side.x.size()); ++i) side.x[i].x() -= 0.1 + beyond;
    self_contact_proximities(params, side.tris, side.rest, side.x, side.x, broad, pairs);
    int32_t over_the_face = 0;
    for (const ProximityPair& q : pairs)
      if (q.vertex >= side.upper_first) over_the_face += std::abs(q.normal.z()) > 1 - 1e-12;
    if (beyond < gap)
      EXPECT_GT(over_the_face, 0) << "beside the border by less than the gap: off the face's plane";
    else
      EXPECT_EQ(over_the_face, 0) << "farther beside the border: no face pair";
  }
}

// Small triangles a cut leaves near a tip: two triangles of the sheet that share no corner but lie within
// two gaps of each other in the pattern are neighbours, however near in space; the same two triangles
// 5 mm apart in the pattern are strangers and make pairs (the control). A 1 mm triangle and, 0.4 mm past
// its long edge, a second one folded over it 0.1 mm above.
TEST(SelfContactProximities, TrianglesWithinTwoGapsInThePatternAreNeighbours) {
  SelfContactParams params;
  params.gap = 3e-4;
  const std::vector<Tri> tris{{0, 1, 2}, {3, 4, 5}};
  const std::vector<Vec3> x{Vec3(0, 0, 0),           Vec3(1e-3, 0, 0),        Vec3(0, 1e-3, 0),
                            Vec3(2e-4, 2e-4, 1e-4), Vec3(6e-4, 2e-4, 1e-4), Vec3(2e-4, 6e-4, 1e-4)};
  for (const double apart : {4e-4, 5e-3}) {
    const Vec2 past = apart * Vec2(1, 1).normalized();  // beyond the edge from (1, 0) mm to (0, 1) mm
    const std::vector<Vec2> rest{Vec2(0, 0),        Vec2(1e-3, 0),           Vec2(0, 1e-3),
                                 Vec2(5e-4, 5e-4) + past, Vec2(1e-3, 1e-3) + past, Vec2(5e-4, 1e-3) + past};
    SelfContactBroadPhasePtr broad;
    std::vector<ProximityPair> pairs;
    self_contact_proximities(params, tris, rest, x, x, broad, pairs);
    if (apart < 2 * params.gap) {
      EXPECT_TRUE(pairs.empty()) << pairs.size() << " pairs between pattern neighbours";
    } else {
      EXPECT_FALSE(pairs.empty()) << "strangers 0.1 mm apart in space";
    }
  }
}

TEST(SelfContact, PairImpulsesConserveMomentum) {
  TwoSheets s = two_sheets(10, 0.001, 0.01, 11);
  for (int32_t i = s.upper_first; i < static_cast<int32_t>(s.x.size()); ++i) s.v[i] = Vec3(0.3, -0.1, -2.0);
  auto momentum = [&] {
    Vec3 p = Vec3::Zero();
    for (size_t i = 0; i < s.x.size(); ++i) p += s.v[i] / s.inverse_mass[i];
    return p;
  };
  const Vec3 before = momentum();
  SelfContactParams params;
  SelfContactBroadPhasePtr broad;
  const SelfContactStats stats = fly(params, s, broad);
  EXPECT_GT(stats.repulsions + stats.collisions, 0);
  const Vec3 after = momentum();
  EXPECT_LT((after - before).norm(), 1e-12 * before.norm()) << (after - before).transpose();
  // And it did change the velocities: the upper sheet was stopped.
  EXPECT_GT(s.v[s.upper_first + 20].z(), -2.0 + 0.1);
}

TEST(SelfContact, SameBitsAtOneAndTwoThreads) {
  auto run = [](int threads) {
    TwoSheets s = two_sheets(16, 0.002, 0.03, 5);
    for (int32_t i = s.upper_first; i < static_cast<int32_t>(s.x.size()); ++i) s.v[i] = Vec3(0.1, 0, -3.0);
    tbb::task_arena arena(threads);
    int64_t candidates = 0;
    arena.execute([&] {
      SelfContactParams params;
      // The engine's runner: its ranges on the arena's threads (1 024 triangles, many ranges of pairs).
      params.run = [](int32_t count, int32_t grain, const RangeTask& task) {
        tbb::parallel_for(
            tbb::blocked_range<int32_t>(0, count, std::max(1, grain)),
            [&](const tbb::blocked_range<int32_t>& r) { task(r.begin(), r.end()); }, tbb::simple_partitioner());
      };
      SelfContactBroadPhasePtr broad;
      for (int step = 0; step < 10; ++step) candidates += fly(params, s, broad).candidates;
    });
    EXPECT_GT(candidates, 10 * 256) << "the pairs span several ranges";
    return s;
  };
  const TwoSheets a = run(1), b = run(2);
  ASSERT_EQ(a.x.size(), b.x.size());
  EXPECT_EQ(std::memcmp(a.x.data(), b.x.data(), a.x.size() * sizeof(Vec3)), 0);
  EXPECT_EQ(std::memcmp(a.v.data(), b.v.data(), a.v.size() * sizeof(Vec3)), 0);
}

// The broad phase's pairs against all pairs tested by brute force, call after call, while the two sheets
// move (the lower one still, the upper one falling and speeding up, one corner of it jerked now and then)
// and their triangles change (a corner replaced by a new vertex, as a cut does, or by another one): the same pairs whether they came from a
// new Embree query or from the cached one, and the cache serves most calls.
class SelfContactCandidates : public testing::TestWithParam<int> {};

TEST_P(SelfContactCandidates, SameAsBruteForceWhetherQueriedOrCached) {
  TwoSheets s = two_sheets(GetParam(), 0.003, 0.02, 11);
  auto brute_force = [&](const std::vector<Vec3>& x0, const std::vector<Vec3>& x1, double margin) {
    std::vector<std::array<int32_t, 2>> pairs;
    auto box = [&](const Tri& t, Vec3& lo, Vec3& hi) {
      lo = hi = x0[t[0]];
      for (int32_t v : t) {
        lo = lo.cwiseMin(x0[v]).cwiseMin(x1[v]);
        hi = hi.cwiseMax(x0[v]).cwiseMax(x1[v]);
      }
      lo.array() -= margin;
      hi.array() += margin;
    };
    for (int32_t a = 0; a < static_cast<int32_t>(s.tris.size()); ++a)
      for (int32_t b = a + 1; b < static_cast<int32_t>(s.tris.size()); ++b) {
        bool shared = false;
        for (int32_t u : s.tris[a])
          for (int32_t w : s.tris[b]) shared = shared || u == w;
        Vec3 lo_a, hi_a, lo_b, hi_b;
        box(s.tris[a], lo_a, hi_a);
        box(s.tris[b], lo_b, hi_b);
        if (!shared && (lo_a.array() <= hi_b.array()).all() && (lo_b.array() <= hi_a.array()).all())
          pairs.push_back({a, b});
      }
    return pairs;
  };
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1, 1);
  SelfContactBroadPhasePtr broad;
  std::vector<std::array<int32_t, 2>> pairs;
  int calls = 0, queries = 0;
  // Still sheets, a narrow margin and then a wide one: the second call's boxes are wider than the cached
  // ones.
  for (const double margin : {3e-6, 6e-4}) {
    queries += self_contact_candidates(s.tris, s.x, s.x, margin, run_serial, broad, pairs);
    calls += 1;
    ASSERT_EQ(pairs, brute_force(s.x, s.x, margin)) << "still, margin " << margin;
  }
  const double h = 1.0 / 300;
  for (int step = 0; step < 60; ++step) {
    for (int32_t i = s.upper_first; i < static_cast<int32_t>(s.x.size()); ++i)
      s.v[i] = Vec3(0.02 * u(rng), 0.02 * u(rng), -0.05 * (1 + step / 10.0));
    if (step % 7 == 3)  // a jerk: 3 mm in one step
      s.v[s.upper_first + step % (static_cast<int32_t>(s.x.size()) - s.upper_first)] = Vec3(u(rng), u(rng), u(rng));
    if (step == 30) {  // a cut: triangle 5's first corner becomes a new vertex at the same place
      s.x.push_back(s.x[s.tris[5][0]]);
      s.v.push_back(Vec3::Zero());
      s.rest.push_back(s.rest[s.tris[5][0]]);
      s.inverse_mass.push_back(s.inverse_mass[s.tris[5][0]]);
      s.tris[5][0] = static_cast<int32_t>(s.x.size()) - 1;
    }
    if (step == 48) s.tris[6][0] = s.upper_first - 2;  // a corner moved to another vertex, far and still
    std::vector<Vec3> x1 = s.x;
    for (size_t i = 0; i < s.x.size(); ++i) x1[i] += h * s.v[i];
    // The substep's calls: the solve's pairs over the predicted paths, then the collision pass's.
    for (const double margin : {6e-4, 3e-6}) {
      queries += self_contact_candidates(s.tris, s.x, x1, margin, run_serial, broad, pairs);
      calls += 1;
      ASSERT_EQ(pairs, brute_force(s.x, x1, margin)) << "step " << step << " margin " << margin;
    }
    s.x = x1;
  }
  EXPECT_LT(queries, calls / 3) << "the cached pairs served most calls";
  EXPECT_GT(queries, 2) << "motion and the cut made it query again";
}

// 100 triangles: the broad phase tests all pairs; 400: Embree's query.
INSTANTIATE_TEST_SUITE_P(AllPairsAndEmbree, SelfContactCandidates, testing::Values(5, 10));

TEST(SelfContact, HeldVerticesKeepTheirPaths) {
  TwoSheets s = two_sheets(8, 0.001, 0, 2);
  for (int32_t i = s.upper_first; i < static_cast<int32_t>(s.x.size()); ++i) s.v[i] = Vec3(0, 0, -1);
  for (int32_t i = 0; i < s.upper_first; ++i) s.inverse_mass[i] = 0;  // the lower sheet is held
  const std::vector<Vec3> lower(s.x.begin(), s.x.begin() + s.upper_first);
  SelfContactParams params;
  SelfContactBroadPhasePtr broad;
  for (int step = 0; step < 10; ++step) fly(params, s, broad);
  for (int32_t i = 0; i < s.upper_first; ++i) EXPECT_EQ(s.x[i], lower[i]);
  EXPECT_EQ(count_self_intersections(s.x, s.tris).intersecting, 0);
  // The held sheet is a floor: the upper one lands on it (its vertices, held by no force, scatter a little
  // off it after their impulses).
  double mean = 0;
  for (int32_t i = s.upper_first; i < static_cast<int32_t>(s.x.size()); ++i) {
    EXPECT_GT(s.x[i].z(), 0) << i;
    mean += s.x[i].z() / (s.x.size() - s.upper_first);
  }
  EXPECT_LT(mean, 0.002);
}


}  // namespace
}  // namespace pt
