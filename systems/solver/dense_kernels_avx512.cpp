// The AVX-512 build of the supernodal factorisation's two products (see dense_kernels.hpp), compiled with
// -mavx512f -mfma -O3 (CMakeLists.txt) and used, with the AVX2 + FMA build's other kernels, on a CPU that has
// AVX-512F. The products are most of a big sheet's factorisation (10 000 triangles: 56–58% of it by perf).
//
// The tiles are the AVX2 build's with eight-lane vectors and eight columns (24 accumulators of the 32
// registers): every entry is one chain of fused multiply-adds over the inner index in increasing order,
// starting from zero, whatever its row, tile or chunk (the last rows of a column go through a masked
// vector), so each entry has the AVX2 build's bits exactly and a factor is the same on both builds
// (tests/solver/dense_kernels_test.cpp checks it entry for entry); it is the faster build on the factorisation's
// shapes (bench/results/2026-11-23-11-notes.txt). It needs the compiler to unroll the tiles' loops (-O3 for
// this file): at -O2 GCC 12 keeps the accumulators on the stack, and the tiles run slower than AVX2's.
#include "systems/solver/dense_kernels.hpp"

#include <immintrin.h>

#include <algorithm>

namespace pt::dense::avx512 {
namespace {

// Lanes 0..r−1 of an eight-lane mask (r in 1..7): the last, partial vector of a column's rows. Masked-off
// lanes are neither read (no fault past the matrix) nor written.
inline __mmask8 first_lanes(int32_t r) { return static_cast<__mmask8>((1u << r) - 1u); }

// C(i .. i+8·RV−1, j .. j+NC−1) = A(rows, :) B(j .. j+NC−1, :)ᵀ, RV vectors of eight rows, the last one
// partial when MASKED. k ≥ 1 (the callers handle k = 0), said to the compiler as in the AVX2 build.
template <int RV, int NC, bool MASKED>
__attribute__((always_inline)) inline void tile(int32_t i, int32_t j, int32_t k, const double* a, int64_t lda,
                                                const double* b, int64_t ldb, double* c, int64_t ldc, __mmask8 mask) {
  __m512d acc[RV][NC];
  for (int r = 0; r < RV; ++r)
    for (int t = 0; t < NC; ++t) acc[r][t] = _mm512_setzero_pd();
  if (k < 1) __builtin_unreachable();
  for (int32_t q = 0; q < k; ++q) {
    const double* aq = a + i + q * lda;
    const double* bq = b + j + q * ldb;
    __m512d av[RV];
    for (int r = 0; r < RV; ++r)
      av[r] = (MASKED && r == RV - 1) ? _mm512_maskz_loadu_pd(mask, aq + 8 * r) : _mm512_loadu_pd(aq + 8 * r);
    for (int t = 0; t < NC; ++t) {
      const __m512d bt = _mm512_set1_pd(bq[t]);
      for (int r = 0; r < RV; ++r) acc[r][t] = _mm512_fmadd_pd(av[r], bt, acc[r][t]);
    }
  }
  for (int t = 0; t < NC; ++t)
    for (int r = 0; r < RV; ++r) {
      double* cc = c + i + 8 * r + (j + t) * ldc;
      if (MASKED && r == RV - 1) _mm512_mask_storeu_pd(cc, mask, acc[r][t]);
      else _mm512_storeu_pd(cc, acc[r][t]);
    }
}

// Rows [i0, i1) of columns j .. j+NC−1: 24 rows per step (three loads and NC broadcasts per 3·NC fused
// multiply-adds), then 16, 8, and a masked last vector.
template <int NC>
void column_block(int32_t i0, int32_t i1, int32_t j, int32_t k, const double* a, int64_t lda, const double* b,
                  int64_t ldb, double* c, int64_t ldc) {
  int32_t i = i0;
  for (; i + 24 <= i1; i += 24) tile<3, NC, false>(i, j, k, a, lda, b, ldb, c, ldc, 0);
  if (i + 16 <= i1) {
    tile<2, NC, false>(i, j, k, a, lda, b, ldb, c, ldc, 0);
    i += 16;
  }
  if (i + 8 <= i1) {
    tile<1, NC, false>(i, j, k, a, lda, b, ldb, c, ldc, 0);
    i += 8;
  }
  if (i < i1) tile<1, NC, true>(i, j, k, a, lda, b, ldb, c, ldc, first_lanes(i1 - i));
}

void column_block_any(int32_t nc, int32_t i0, int32_t i1, int32_t j, int32_t k, const double* a, int64_t lda,
                      const double* b, int64_t ldb, double* c, int64_t ldc) {
  switch (nc) {
    case 8: column_block<8>(i0, i1, j, k, a, lda, b, ldb, c, ldc); break;
    case 7: column_block<7>(i0, i1, j, k, a, lda, b, ldb, c, ldc); break;
    case 6: column_block<6>(i0, i1, j, k, a, lda, b, ldb, c, ldc); break;
    case 5: column_block<5>(i0, i1, j, k, a, lda, b, ldb, c, ldc); break;
    case 4: column_block<4>(i0, i1, j, k, a, lda, b, ldb, c, ldc); break;
    case 3: column_block<3>(i0, i1, j, k, a, lda, b, ldb, c, ldc); break;
    case 2: column_block<2>(i0, i1, j, k, a, lda, b, ldb, c, ldc); break;
    case 1: column_block<1>(i0, i1, j, k, a, lda, b, ldb, c, ldc); break;
    default: break;
  }
}

// C = 0 for an empty inner dimension: rows [first_row(j), m) of each column j. (The AVX2 file has the same
// helpers; they are not shared on purpose: an inline function of a header included by files compiled for
// different instruction sets could be linked from either one.)
template <typename FirstRow>
void zero_columns(int32_t m, int32_t n, double* c, int64_t ldc, FirstRow first_row) {
  for (int32_t j = 0; j < n; ++j) std::fill(c + first_row(j) + j * ldc, c + m + j * ldc, 0.0);
}

void gemm_nt(int32_t m, int32_t n, int32_t k, const double* a, int64_t lda, const double* b, int64_t ldb, double* c,
             int64_t ldc) {
  if (k < 1) return zero_columns(m, n, c, ldc, [](int32_t) { return 0; });
  for (int32_t j = 0; j < n; j += 8) column_block_any(std::min<int32_t>(8, n - j), 0, m, j, k, a, lda, b, ldb, c, ldc);
}

// The lower triangle, by blocks of (up to) eight columns from their diagonal down; the block on the
// diagonal computed whole into a scratch and only its lower part copied (the same chains as gemm_nt's).
void syrk_lower(int32_t n, int32_t k, const double* a, int64_t lda, double* c, int64_t ldc) {
  if (k < 1) return zero_columns(n, n, c, ldc, [](int32_t j) { return j; });
  for (int32_t j = 0; j < n; j += 8) {
    const int32_t nc = std::min<int32_t>(8, n - j);
    double block[64];
    column_block_any(nc, 0, nc, 0, k, a + j, lda, a + j, lda, block, 8);
    for (int32_t t = 0; t < nc; ++t)
      for (int32_t r = t; r < nc; ++r) c[(j + r) + (j + t) * ldc] = block[r + 8 * t];
    column_block_any(nc, j + nc, n, j, k, a, lda, a, lda, c, ldc);
  }
}

}  // namespace

// Replaces the two products of a table that holds the AVX2 + FMA build.
void fill_products(DenseKernels& k) {
  k.syrk_lower = syrk_lower;
  k.gemm_nt = gemm_nt;
}

}  // namespace pt::dense::avx512
