// T_fiber (paper §4.2, eq. 3 and eq. 7): range, determinism, seeding, bilinear texture, fractal structure.
#include "systems/tearing/fiber_field.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace pt {
namespace {

FiberField field(uint64_t seed) {
  FiberField f;
  f.seed = seed;
  return f;
}

TEST(FiberField, RangeAndMean) {
  const FiberField f = field(7);
  double sum = 0, sum2 = 0;
  int n = 0;
  for (int j = 0; j < 300; ++j)
    for (int i = 0; i < 300; ++i) {
      const double t = fiber_texel(f, i * 3, j * 3);
      ASSERT_GE(t, 0.0);
      ASSERT_LE(t, 1.0);
      sum += t;
      sum2 += t * t;
      ++n;
    }
  const double mean = sum / n, var = sum2 / n - mean * mean;
  EXPECT_NEAR(mean, 0.5, 0.06);
  // Typical values spread across the range (the affine map is not a near-constant).
  EXPECT_GT(std::sqrt(var), 0.12);
  EXPECT_LT(std::sqrt(var), 0.35);
}

TEST(FiberField, Deterministic) {
  const FiberField a = field(42), b = field(42);
  for (int k = 0; k < 100; ++k) {
    const Vec2 p(0.0013 * k, 0.0021 * k - 0.01);
    EXPECT_EQ(fiber_noise(a, p), fiber_noise(b, p));
    EXPECT_EQ(fiber_sample(a, p), fiber_sample(b, p));
    EXPECT_EQ(fiber_texel(a, k, 3 * k), fiber_texel(b, k, 3 * k));
  }
}

TEST(FiberField, DifferentSeedsDiffer) {
  const FiberField a = field(1), b = field(2);
  int differ = 0;
  double diff = 0;
  for (int k = 0; k < 200; ++k) {
    const double ta = fiber_texel(a, 7 * k, 11 * k), tb = fiber_texel(b, 7 * k, 11 * k);
    differ += ta != tb;
    diff += std::abs(ta - tb);
  }
  EXPECT_GT(differ, 190);
  EXPECT_GT(diff / 200, 0.05);
}

TEST(FiberField, SampleAtTexelCentreEqualsTexel) {
  FiberField f = field(3);
  f.origin = Vec2(-0.01, 0.02);
  f.pixel_size = 2e-4;
  for (int k = -20; k < 20; ++k) {
    const int i = 5 * k, j = 3 * k + 1;
    const Vec2 c = f.origin + Vec2((i + 0.5) * f.pixel_size, (j + 0.5) * f.pixel_size);
    EXPECT_NEAR(fiber_sample(f, c), fiber_texel(f, i, j), 1e-12);
  }
}

TEST(FiberField, SampleIsBilinearBetweenCentres) {
  const FiberField f = field(5);
  const Vec2 c00 = f.origin + Vec2(10.5 * f.pixel_size, 20.5 * f.pixel_size);
  const Vec2 mid = c00 + Vec2(0.5 * f.pixel_size, 0.5 * f.pixel_size);
  const double expect = 0.25 * (fiber_texel(f, 10, 20) + fiber_texel(f, 11, 20) + fiber_texel(f, 10, 21) +
                                fiber_texel(f, 11, 21));
  EXPECT_NEAR(fiber_sample(f, mid), expect, 1e-12);
}

TEST(FiberField, RowEqualsTexels) {
  FiberField f = field(13);
  f.origin = Vec2(-0.003, 0.011);
  for (int j : {-7, 0, 5, 333}) {
    std::vector<double> row(300);
    fiber_row(f, j, -40, 300, row.data());
    for (int c = 0; c < 300; ++c) ASSERT_EQ(row[c], fiber_texel(f, c - 40, j)) << c << "," << j;
  }
}

TEST(FiberField, Continuous) {
  const FiberField f = field(9);
  // Small moves give small changes, both for the procedural field and its bilinear texture.
  for (int k = 0; k < 500; ++k) {
    const Vec2 p(0.00037 * k, 0.00053 * k);
    const Vec2 q = p + Vec2(1e-7, -1e-7);
    EXPECT_LT(std::abs(fiber_noise(f, p) - fiber_noise(f, q)), 0.01);
    EXPECT_LT(std::abs(fiber_sample(f, p) - fiber_sample(f, q)), 0.01);
  }
}

// Mean squared difference between points h apart.
double structure(const FiberField& f, double h) {
  double s = 0;
  int n = 0;
  for (int j = 0; j < 60; ++j)
    for (int i = 0; i < 60; ++i) {
      const Vec2 p(0.0011 * i, 0.0013 * j);
      const double d = fiber_noise(f, p) - fiber_noise(f, p + Vec2(h, 0));
      s += d * d;
      ++n;
    }
  return s / n;
}

TEST(FiberField, OctavesAddSmallScaleVariation) {
  FiberField one = field(11);
  one.octaves = 1;
  FiberField many = field(11);
  many.octaves = 5;
  // At a twentieth of the feature size a single octave is almost flat; the finer octaves add variation
  // there (relative to the variation at the feature size, since the octave count changes the normalisation).
  const double h = many.feature_size / 20;
  EXPECT_GT(structure(many, h) / structure(many, many.feature_size),
            1.5 * structure(one, h) / structure(one, one.feature_size));
  // Small-scale variation exists at all (not just a smooth blob).
  EXPECT_GT(structure(many, h), 1e-4);
}

}  // namespace
}  // namespace pt
