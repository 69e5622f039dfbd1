// The dense kernels of the supernodal factorisation (systems/solver/dense_kernels.hpp), each build that this CPU
// runs (baseline, AVX2 + FMA and AVX-512 where available), against plain loops: products, the Cholesky
// factor and the triangular solve, on strided panels with guard values around them that must stay
// untouched; and the AVX-512 products against the AVX2 ones, bit for bit.
#include "systems/solver/dense_kernels.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <vector>

namespace pt {
namespace {

std::vector<const DenseKernels*> builds() {
  std::vector<const DenseKernels*> b{&baseline_dense_kernels()};
  if (const DenseKernels* a = avx2_dense_kernels()) b.push_back(a);
  if (const DenseKernels* a = avx512_dense_kernels()) b.push_back(a);
  return b;
}

// A column-major m × n matrix inside a buffer of leading dimension ld > m, the rest filled with `guard`.
struct Strided {
  int32_t m, n;
  int64_t ld;
  std::vector<double> data;
  Strided(int32_t rows, int32_t cols, int64_t lead, double guard)
      : m(rows), n(cols), ld(lead), data(lead * cols + 7, guard) {}
  double& operator()(int32_t i, int32_t j) { return data[i + j * ld]; }
  double operator()(int32_t i, int32_t j) const { return data[i + j * ld]; }
};

Strided random_matrix(int32_t m, int32_t n, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Strided a(m, n, m + 5, 1234.5);
  for (int32_t j = 0; j < n; ++j)
    for (int32_t i = 0; i < m; ++i) a(i, j) = u(rng);
  return a;
}

void expect_guards(const Strided& a, double guard) {
  for (size_t q = 0; q < a.data.size(); ++q) {
    const int64_t i = static_cast<int64_t>(q) % a.ld, j = static_cast<int64_t>(q) / a.ld;
    if (i >= a.m || j >= a.n) {
      ASSERT_EQ(a.data[q], guard) << "written outside the matrix at " << q;
    }
  }
}

TEST(DenseKernels, ProductsMatchLoops) {
  std::mt19937 rng(7);
  for (const DenseKernels* kern : builds())
    for (const auto [m, n, k] :
         {std::array{3, 3, 3}, std::array{12, 9, 6}, std::array{37, 21, 48}, std::array{96, 60, 33},
          std::array{7, 5, 0}}) {  // k = 0: C = 0
      const Strided a = random_matrix(m, k, rng), b = random_matrix(n, k, rng);
      Strided c(m, n, m + 3, -7.0);
      kern->gemm_nt(m, n, k, a.data.data(), a.ld, b.data.data(), b.ld, c.data.data(), c.ld);
      for (int32_t i = 0; i < m; ++i)
        for (int32_t j = 0; j < n; ++j) {
          double s = 0;
          for (int32_t q = 0; q < k; ++q) s += a(i, q) * b(j, q);
          ASSERT_NEAR(c(i, j), s, 1e-12 * k) << kern->name << " gemm " << m << "x" << n << "x" << k;
        }
      expect_guards(c, -7.0);

      Strided l(n, n, n + 2, -7.0);
      for (int32_t j = 0; j < n; ++j)
        for (int32_t i = 0; i < j; ++i) l(i, j) = 99.0;  // strict upper triangle: must stay
      const Strided x = random_matrix(n, k, rng);
      kern->syrk_lower(n, k, x.data.data(), x.ld, l.data.data(), l.ld);
      for (int32_t j = 0; j < n; ++j)
        for (int32_t i = 0; i < n; ++i) {
          if (i < j) {
            ASSERT_EQ(l(i, j), 99.0) << kern->name << " syrk wrote above the diagonal";
            continue;
          }
          double s = 0;
          for (int32_t q = 0; q < k; ++q) s += x(i, q) * x(j, q);
          ASSERT_NEAR(l(i, j), s, 1e-12 * k) << kern->name << " syrk " << n << "x" << k;
        }
      expect_guards(l, -7.0);
    }
}

TEST(DenseKernels, CholeskyAndSolveMatchLoops) {
  std::mt19937 rng(11);
  for (const DenseKernels* kern : builds())
    for (const int32_t n : {3, 9, 30, 75}) {
      // A = X Xᵀ + n I: symmetric positive definite.
      const Strided x = random_matrix(n, n, rng);
      Strided a(n, n, n + 4, 5.5);
      for (int32_t i = 0; i < n; ++i)
        for (int32_t j = 0; j < n; ++j) {
          double s = i == j ? n : 0.0;
          for (int32_t q = 0; q < n; ++q) s += x(i, q) * x(j, q);
          a(i, j) = s;
        }
      const Strided original = a;
      ASSERT_TRUE(kern->llt_lower(n, a.data.data(), a.ld)) << kern->name;
      expect_guards(a, 5.5);
      // L Lᵀ = A on the lower triangle.
      for (int32_t i = 0; i < n; ++i)
        for (int32_t j = 0; j <= i; ++j) {
          double s = 0;
          for (int32_t q = 0; q <= j; ++q) s += a(i, q) * a(j, q);
          ASSERT_NEAR(s, original(i, j), 1e-11 * n) << kern->name << " llt " << n;
        }
      // B L⁻ᵀ: (result) Lᵀ = B.
      const int32_t m = n + 7;
      const Strided b = random_matrix(m, n, rng);
      Strided y = b;
      kern->solve_right_lower_transposed(m, n, a.data.data(), a.ld, y.data.data(), y.ld);
      for (int32_t i = 0; i < m; ++i)
        for (int32_t j = 0; j < n; ++j) {
          double s = 0;
          for (int32_t q = 0; q <= j; ++q) s += y(i, q) * a(j, q);  // (Y Lᵀ)(i, j) = Σ_q Y(i, q) L(j, q)
          ASSERT_NEAR(s, b(i, j), 1e-10 * n) << kern->name << " solve " << m << "x" << n;
        }
      expect_guards(y, 1234.5);
    }
}

// The column factorisation's update: y[rows[q]] −= blocks[q] · x on 3 × 3 blocks, rows in any order and
// repeated, the arrays ending right after their last block (a kernel must not read or write past them:
// the blocks are copied into an exact-size vector, and y has a guard block after it).
TEST(DenseKernels, BlockProductsSubtractedMatchLoops) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (const DenseKernels* kern : builds())
    for (const int32_t count : {1, 2, 7, 40}) {
      std::vector<int32_t> rows(count);
      for (int32_t q = 0; q < count; ++q) rows[q] = (7 * q + 3) % 5;  // five target blocks, hit repeatedly
      std::vector<double> blocks(9 * count), x(9), y(9 * 6);
      for (double& v : blocks) v = u(rng);
      for (double& v : x) v = u(rng);
      for (double& v : y) v = u(rng);
      const std::vector<double> y0 = y;
      kern->subtract_block_products(count, rows.data(), blocks.data(), x.data(), y.data());
      std::vector<double> expect = y0;
      for (int32_t q = 0; q < count; ++q)
        for (int c = 0; c < 3; ++c)
          for (int r = 0; r < 3; ++r) {
            double s = 0;
            for (int k = 0; k < 3; ++k) s += blocks[9 * q + r + 3 * k] * x[k + 3 * c];
            expect[9 * rows[q] + r + 3 * c] -= s;
          }
      for (int e = 0; e < 45; ++e) ASSERT_NEAR(y[e], expect[e], 1e-12 * count) << kern->name << " entry " << e;
      for (int e = 45; e < 54; ++e) ASSERT_EQ(y[e], y0[e]) << kern->name << " wrote into the guard block";
    }
}

// The supernodal solve at one panel: the n × n lower triangle L₁₁ on top of the m rows L₂₁, column-major.
// Forward: L₁₁ y' = y, t = L₂₁ y'. Backward: L₁₁ᵀ y' = y − L₂₁ᵀ t. Checked by multiplying back; y and t sit
// between guard values that must stay.
TEST(DenseKernels, PanelSolvesMatchLoops) {
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (const DenseKernels* kern : builds())
    for (const auto [n, m] : {std::array{1, 0}, std::array{3, 5}, std::array{9, 17}, std::array{30, 37},
                              std::array{96, 101}}) {
      Strided l(n + m, n, n + m + 3, -3.0);
      for (int32_t j = 0; j < n; ++j) {
        for (int32_t i = 0; i < n; ++i) l(i, j) = i == j ? 2.0 + u(rng) : (i > j ? 0.3 * u(rng) : 77.0);
        for (int32_t i = n; i < n + m; ++i) l(i, j) = u(rng);
      }
      const double guard = 555.0;
      std::vector<double> y(n + 2, guard), t(m + 2, guard), y0(n);
      for (double& v : y0) v = u(rng);
      std::copy(y0.begin(), y0.end(), y.begin() + 1);
      kern->panel_forward(n, m, l.data.data(), l.ld, y.data() + 1, t.data() + 1);
      for (int32_t i = 0; i < n; ++i) {
        double s = 0;
        for (int32_t j = 0; j <= i; ++j) s += l(i, j) * y[1 + j];
        ASSERT_NEAR(s, y0[i], 1e-12 * n) << kern->name << " forward " << n << "x" << m;
      }
      for (int32_t i = 0; i < m; ++i) {
        double s = 0;
        for (int32_t j = 0; j < n; ++j) s += l(n + i, j) * y[1 + j];
        ASSERT_NEAR(t[1 + i], s, 1e-12 * n) << kern->name << " forward product " << n << "x" << m;
      }
      ASSERT_TRUE(y.front() == guard && y.back() == guard && t.front() == guard && t.back() == guard) << kern->name;

      std::vector<double> b(m + 2, guard);
      for (int32_t i = 0; i < m; ++i) b[1 + i] = u(rng);
      std::copy(y0.begin(), y0.end(), y.begin() + 1);
      kern->panel_backward(n, m, l.data.data(), l.ld, b.data() + 1, y.data() + 1);
      for (int32_t j = 0; j < n; ++j) {
        double lhs = 0, rhs = y0[j];
        for (int32_t i = j; i < n; ++i) lhs += l(i, j) * y[1 + i];
        for (int32_t i = 0; i < m; ++i) rhs -= l(n + i, j) * b[1 + i];
        ASSERT_NEAR(lhs, rhs, 1e-12 * (n + m)) << kern->name << " backward " << n << "x" << m;
      }
      ASSERT_TRUE(y.front() == guard && y.back() == guard) << kern->name;
      expect_guards(l, -3.0);
    }
}

TEST(DenseKernels, CholeskyRefusesWhatIsNotPositiveDefinite) {
  for (const DenseKernels* kern : builds()) {
    Strided a(3, 3, 3, 0.0);
    a(0, 0) = 1, a(1, 1) = -2, a(2, 2) = 1;
    EXPECT_FALSE(kern->llt_lower(3, a.data.data(), a.ld)) << kern->name;
    Strided b(2, 2, 2, 0.0);
    b(0, 0) = std::nan(""), b(1, 1) = 1;
    EXPECT_FALSE(kern->llt_lower(2, b.data.data(), b.ld)) << kern->name;
  }
}

const DenseKernels& fastest_build() {
  if (const DenseKernels* a = avx512_dense_kernels()) return *a;
  if (const DenseKernels* a = avx2_dense_kernels()) return *a;
  return baseline_dense_kernels();
}

// The library reads no environment: the programs pass PAPERTEAR_DENSE_KERNELS on with
// select_dense_kernels. A variable set before the process's first factorisation (this test is the suite's
// first use of dense_kernels()) changes nothing.
TEST(DenseKernels, ThisCpuUsesTheFastestBuildItHasWhateverTheEnvironment) {
  ASSERT_EQ(setenv("PAPERTEAR_DENSE_KERNELS", "baseline", 1), 0);
  const DenseKernels& k = dense_kernels();
  unsetenv("PAPERTEAR_DENSE_KERNELS");
  EXPECT_EQ(&k, &fastest_build()) << k.name;
  std::printf("dense kernels: %s\n", k.name);
}

// What each choice selects, named as PAPERTEAR_DENSE_KERNELS names them.
TEST(DenseKernels, SelectedBuildIsTheOneUsed) {
  DenseKernelChoice choice = DenseKernelChoice::Fastest;
  ASSERT_TRUE(dense_kernel_choice_from_name("baseline", choice));
  EXPECT_EQ(choice, DenseKernelChoice::Baseline);
  select_dense_kernels(choice);
  EXPECT_EQ(&dense_kernels(), &baseline_dense_kernels());
  ASSERT_TRUE(dense_kernel_choice_from_name("avx2", choice));
  EXPECT_EQ(choice, DenseKernelChoice::Avx2);
  select_dense_kernels(choice);
  EXPECT_EQ(&dense_kernels(), avx2_dense_kernels() ? avx2_dense_kernels() : &baseline_dense_kernels());
  select_dense_kernels(DenseKernelChoice::Fastest);
  EXPECT_EQ(&dense_kernels(), &fastest_build());
  for (const char* bad : {"", "AVX2", "avx512", "fastest"})
    EXPECT_FALSE(dense_kernel_choice_from_name(bad, choice)) << bad;
  EXPECT_FALSE(dense_kernel_choice_from_name(nullptr, choice));
}

// The AVX-512 products promise the AVX2 build's bits (a factor must not depend on which of the two a CPU
// has): every entry of C, on shapes through all of both builds' row tiles, column blocks and masked rows,
// with strided operands, and C's guard values around it untouched.
TEST(DenseKernels, Avx512ProductsAreTheAvx2Bits) {
  const DenseKernels* wide = avx512_dense_kernels();
  const DenseKernels* avx2 = avx2_dense_kernels();
  if (!wide || !avx2) GTEST_SKIP() << "this CPU or build has no AVX-512 products";
  std::mt19937 rng(11);
  std::uniform_int_distribution<int32_t> size(1, 60), inner(0, 100);
  int32_t shapes = 0;
  auto compare = [&](int32_t m, int32_t n, int32_t k) {
    const Strided a = random_matrix(m, k, rng), b = random_matrix(n, k, rng);
    Strided c_wide(m, n, m + 3, -7.0), c_avx2(m, n, m + 3, -7.0);
    wide->gemm_nt(m, n, k, a.data.data(), a.ld, b.data.data(), b.ld, c_wide.data.data(), c_wide.ld);
    avx2->gemm_nt(m, n, k, a.data.data(), a.ld, b.data.data(), b.ld, c_avx2.data.data(), c_avx2.ld);
    for (int32_t i = 0; i < m; ++i)
      for (int32_t j = 0; j < n; ++j)
        ASSERT_EQ(c_wide(i, j), c_avx2(i, j)) << "gemm " << m << "x" << n << "x" << k << " at " << i << "," << j;
    expect_guards(c_wide, -7.0);
    Strided l_wide(m, m, m + 2, -7.0), l_avx2(m, m, m + 2, -7.0);
    for (int32_t j = 0; j < m; ++j)
      for (int32_t i = 0; i < j; ++i) l_wide(i, j) = l_avx2(i, j) = 99.0;  // strict upper triangle: must stay
    wide->syrk_lower(m, k, a.data.data(), a.ld, l_wide.data.data(), l_wide.ld);
    avx2->syrk_lower(m, k, a.data.data(), a.ld, l_avx2.data.data(), l_avx2.ld);
    for (int32_t j = 0; j < m; ++j)
      for (int32_t i = 0; i < m; ++i)
        ASSERT_EQ(l_wide(i, j), l_avx2(i, j)) << "syrk " << m << "x" << k << " at " << i << "," << j;
    expect_guards(l_wide, -7.0);
    ++shapes;
  };
  for (int32_t m : {1, 7, 8, 9, 15, 16, 17, 23, 24, 25, 47, 48, 49, 96})
    for (int32_t n : {1, 3, 5, 8, 9, 16, 21})
      for (int32_t k : {0, 1, 3, 48}) compare(m, n, k);
  for (int round = 0; round < 200; ++round) compare(size(rng), size(rng), inner(rng));
  EXPECT_EQ(shapes, 14 * 7 * 4 + 200);
}

}  // namespace
}  // namespace pt
