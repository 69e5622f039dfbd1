// Regions of analytic shapes (issue 4): a flat sheet is one flat region; a sheet bent into a cylinder
// over its middle third is flat–curved–flat with four junction points on the boundary; an S-bend gives
// two curved regions of opposite sign. The bending estimate of a cylinder of radius r is 1/r.
#include "systems/tearing/regions.hpp"
#include "tests/test_meshes.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

using namespace pt;

namespace {
// Bends the band a ≤ u ≤ b around a cylinder of radius r whose axis is parallel to v; the parts
// outside stay flat and tangent (an isometry of the pattern). sign picks the side the sheet turns to.
Vec3 bend(const Vec2& p, double a, double b, double r, double sign) {
  const double u = p.x();
  if (u <= a) return Vec3(u, p.y(), 0);
  const double s = std::min(u, b) - a;  // arc length on the cylinder
  const double th = s / r;
  Vec3 q(a + r * std::sin(th), p.y(), sign * r * (1 - std::cos(th)));
  if (u > b) {
    const double extra = u - b;
    q += extra * Vec3(std::cos(th), 0, sign * std::sin(th));
  }
  return q;
}

int count_flag(const Sheet& s, uint8_t flag) {
  int n = 0;
  for (uint8_t f : s.verts.flags) n += (f & flag) ? 1 : 0;
  return n;
}
}  // namespace

TEST(Regions, FlatSheetIsOneFlatRegion) {
  Sheet s = test::grid_sheet(0.2, 0.1, 20, 10, 0.2);
  const RegionSummary sum = classify_regions(s.verts.x, s.tris.tri, s.topo, RegionParams{}, s.tris.region, s.regions,
                                             s.verts.flags);
  EXPECT_EQ(sum.regions, 1);
  EXPECT_EQ(sum.junctions, 0);
  EXPECT_EQ(s.regions[0].kind, RegionKind::Flat);
  EXPECT_EQ(s.regions[0].triangle_count, s.tris.size());
}

TEST(Regions, CylinderBendingEstimateIsOneOverRadius) {
  Sheet s = test::grid_sheet(0.2, 0.1, 40, 20);
  const double r = 0.05;
  for (int i = 0; i < s.verts.size(); ++i) s.verts.x[i] = bend(s.verts.rest[i], -1, 1, r, 1);
  std::vector<double> bending;
  triangle_bending(s.verts.x, s.tris.tri, s.topo, bending);
  // Interior triangles (all three edges shared) see the full curvature.
  int checked = 0;
  for (int t = 0; t < s.tris.size(); ++t) {
    if (s.topo.neighbor[t][0] < 0 || s.topo.neighbor[t][1] < 0 || s.topo.neighbor[t][2] < 0) continue;
    EXPECT_NEAR(std::abs(bending[t]), 1 / r, 0.1 / r) << t;
    ++checked;
  }
  EXPECT_GT(checked, 100);
}

TEST(Regions, CylinderOverTheMiddleIsFlatCurvedFlatWithFourJunctions) {
  Sheet s = test::grid_sheet(0.21, 0.1, 42, 20);
  for (int i = 0; i < s.verts.size(); ++i) s.verts.x[i] = bend(s.verts.rest[i], 0.07, 0.14, 0.04, 1);
  const RegionSummary sum = classify_regions(s.verts.x, s.tris.tri, s.topo, RegionParams{}, s.tris.region, s.regions,
                                             s.verts.flags);
  ASSERT_EQ(sum.regions, 3);
  int flat = 0, curved = 0;
  for (const Region& r : s.regions) (r.kind == RegionKind::Flat ? flat : curved) += 1;
  EXPECT_EQ(flat, 2);
  EXPECT_EQ(curved, 1);
  // Junction points sit where the boundary (v = 0 and v = h) crosses the two region borders.
  EXPECT_EQ(count_flag(s, kJunction), sum.junctions);
  int near_borders = 0;
  for (int v = 0; v < s.verts.size(); ++v)
    if (s.verts.flags[v] & kJunction) {
      const Vec2 p = s.verts.rest[v];
      EXPECT_TRUE(p.y() < 1e-9 || p.y() > 0.1 - 1e-9) << "junction off the long edges at " << p.transpose();
      EXPECT_TRUE(std::abs(p.x() - 0.07) < 0.011 || std::abs(p.x() - 0.14) < 0.011) << p.transpose();
      ++near_borders;
    }
  // One junction cluster at each of the four crossings (a crossing may mark two adjacent vertices).
  EXPECT_GE(near_borders, 4);
  EXPECT_LE(near_borders, 8);
  auto crossing_has_junction = [&](double u, double v) {
    for (int k = 0; k < s.verts.size(); ++k)
      if ((s.verts.flags[k] & kJunction) && std::abs(s.verts.rest[k].x() - u) < 0.011 &&
          std::abs(s.verts.rest[k].y() - v) < 1e-9)
        return true;
    return false;
  };
  EXPECT_TRUE(crossing_has_junction(0.07, 0.0));
  EXPECT_TRUE(crossing_has_junction(0.14, 0.0));
  EXPECT_TRUE(crossing_has_junction(0.07, 0.1));
  EXPECT_TRUE(crossing_has_junction(0.14, 0.1));
}

TEST(Regions, SBendGivesTwoCurvedRegionsOfOppositeSign) {
  Sheet s = test::grid_sheet(0.2, 0.1, 40, 20);
  // First half curves up, second half curves down (an S), both with radius 5 cm.
  const double r = 0.05;
  for (int i = 0; i < s.verts.size(); ++i) {
    const Vec2 p = s.verts.rest[i];
    if (p.x() <= 0.1) {
      s.verts.x[i] = bend(p, -1, 1, r, 1);
    } else {
      // Continue from the end of the first arc with opposite curvature.
      const double th0 = 0.1 / r;
      const Vec3 end(r * std::sin(th0), p.y(), r * (1 - std::cos(th0)));
      const Vec3 t(std::cos(th0), 0, std::sin(th0));
      const Vec3 n(-std::sin(th0), 0, std::cos(th0));
      const double th = (p.x() - 0.1) / r;
      s.verts.x[i] = end + r * std::sin(th) * t - r * (1 - std::cos(th)) * n;
    }
  }
  const RegionSummary sum = classify_regions(s.verts.x, s.tris.tri, s.topo, RegionParams{}, s.tris.region, s.regions,
                                             s.verts.flags);
  int pos = 0, neg = 0;
  for (const Region& reg : s.regions) {
    if (reg.kind == RegionKind::CurvedPositive && reg.triangle_count > 50) ++pos;
    if (reg.kind == RegionKind::CurvedNegative && reg.triangle_count > 50) ++neg;
  }
  EXPECT_EQ(pos, 1);
  EXPECT_EQ(neg, 1);
  EXPECT_GE(sum.junctions, 2);  // where the two curved regions meet on each long edge
}

TEST(Regions, IdsAreDeterministic) {
  Sheet s = test::grid_sheet(0.21, 0.1, 42, 20, 0.2, 7);
  for (int i = 0; i < s.verts.size(); ++i) s.verts.x[i] = bend(s.verts.rest[i], 0.07, 0.14, 0.04, -1);
  std::vector<int32_t> a, b;
  std::vector<Region> ra, rb;
  std::vector<uint8_t> fa = s.verts.flags, fb = s.verts.flags;
  classify_regions(s.verts.x, s.tris.tri, s.topo, RegionParams{}, a, ra, fa);
  classify_regions(s.verts.x, s.tris.tri, s.topo, RegionParams{}, b, rb, fb);
  EXPECT_EQ(a, b);
  EXPECT_EQ(fa, fb);
}

// Mesh-scale noise: a lone curved triangle in a flat sheet joins the flat region (min_region_triangles),
// and smoothing passes spread and shrink a one-triangle spike.
TEST(Regions, SmallRegionsMergeIntoTheirNeighbour) {
  Sheet s = test::grid_sheet(0.2, 0.1, 20, 10);
  // Lift one interior vertex: its fan bends, a few triangles' worth of "curvature".
  const int32_t v = 5 * 21 + 10;
  s.verts.x[v].z() = 0.002;
  RegionParams keep;
  keep.min_region_triangles = 1;
  std::vector<int32_t> tri_region;
  std::vector<Region> regions;
  std::vector<uint8_t> flags = s.verts.flags;
  const RegionSummary raw = classify_regions(s.verts.x, s.tris.tri, s.topo, keep, tri_region, regions, flags);
  EXPECT_GT(raw.regions, 1);
  RegionParams merge;
  merge.min_region_triangles = 12;
  const RegionSummary merged = classify_regions(s.verts.x, s.tris.tri, s.topo, merge, tri_region, regions, flags);
  EXPECT_EQ(merged.regions, 1);
  EXPECT_EQ(regions[0].kind, RegionKind::Flat);
  std::vector<double> before, after;
  triangle_bending(s.verts.x, s.tris.tri, s.topo, before);
  RegionParams smooth = keep;
  smooth.smoothing_passes = 2;
  const RegionSummary smoothed = classify_regions(s.verts.x, s.tris.tri, s.topo, smooth, tri_region, regions, flags);
  EXPECT_LE(smoothed.regions, raw.regions);
}
