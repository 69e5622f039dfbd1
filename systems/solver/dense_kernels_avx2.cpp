// The AVX2 + FMA build of the dense kernels (see dense_kernels.hpp), compiled with -mavx2 -mfma and
// -DEigen=PtEigenAvx2 (CMakeLists.txt); it includes nothing that brings in Eigen under its own name.
//
// The products and the triangular solve are written out here rather than taken from Eigen: Eigen's AVX
// kernels treat the rows of a panel differently by their position in it (packets, remainders), so a row
// chunk's results would depend on where the chunk begins, and the factor on how the panels were chunked,
// that is on the thread count. Here every entry is one chain of fused multiply-adds over the inner index
// in increasing order, computed in a vector lane whatever its row (a column's last rows go through a
// masked vector, not a scalar path), so an entry's bits do not depend on the chunk, the row block or the
// kernel (the lower triangle of syrk_lower equals gemm_nt's entries).
#include "systems/solver/dense_kernels.hpp"

#include <immintrin.h>

#include <algorithm>
#include <cmath>

#define PT_DENSE_BUILD avx2
#include "systems/solver/dense_kernels_impl.inc"

namespace pt::dense::avx2 {
namespace {

// Lanes 0..r−1 of a 4-lane mask (r in 1..3): the last, partial vector of a column's rows. Masked-off lanes
// are neither read (no fault past the matrix) nor written.
inline __m256i first_lanes(int32_t r) {
  return _mm256_cmpgt_epi64(_mm256_set1_epi64x(r), _mm256_setr_epi64x(0, 1, 2, 3));
}

// C(i .. i+4·RV−1, j .. j+NC−1) = A(rows, :) B(j .. j+NC−1, :)ᵀ, RV vectors of four rows, the last one
// partial when MASKED. RV·NC accumulators, one fused multiply-add chain per entry over q = 0, 1, … k−1.
// k ≥ 1 (the callers handle k = 0). Said to the compiler, and the tile inlined into its row loop: otherwise
// GCC 12 keeps a stack copy of the accumulators for the case of no iteration and stores all twelve to it
// in every iteration, and the loop runs at the store port's pace, not the fused multiply-adds' (half the
// speed).
template <int RV, int NC, bool MASKED>
__attribute__((always_inline)) inline void tile(int32_t i, int32_t j, int32_t k, const double* a, int64_t lda,
                                                const double* b, int64_t ldb, double* c, int64_t ldc, __m256i mask) {
  __m256d acc[RV][NC];
  for (int r = 0; r < RV; ++r)
    for (int t = 0; t < NC; ++t) acc[r][t] = _mm256_setzero_pd();
  if (k < 1) __builtin_unreachable();
  for (int32_t q = 0; q < k; ++q) {
    const double* aq = a + i + q * lda;
    const double* bq = b + j + q * ldb;
    __m256d av[RV];
    for (int r = 0; r < RV; ++r)
      av[r] = (MASKED && r == RV - 1) ? _mm256_maskload_pd(aq + 4 * r, mask) : _mm256_loadu_pd(aq + 4 * r);
    for (int t = 0; t < NC; ++t) {
      const __m256d bt = _mm256_broadcast_sd(bq + t);
      for (int r = 0; r < RV; ++r) acc[r][t] = _mm256_fmadd_pd(av[r], bt, acc[r][t]);
    }
  }
  for (int t = 0; t < NC; ++t)
    for (int r = 0; r < RV; ++r) {
      double* cc = c + i + 4 * r + (j + t) * ldc;
      if (MASKED && r == RV - 1) _mm256_maskstore_pd(cc, mask, acc[r][t]);
      else _mm256_storeu_pd(cc, acc[r][t]);
    }
}

// Rows [i0, i1) of columns j .. j+NC−1: twelve rows per step (three loads and NC broadcasts per 3·NC
// fused multiply-adds), then eight, four, and a masked last vector.
template <int NC>
void column_block(int32_t i0, int32_t i1, int32_t j, int32_t k, const double* a, int64_t lda, const double* b,
                  int64_t ldb, double* c, int64_t ldc) {
  const __m256i none = _mm256_setzero_si256();
  int32_t i = i0;
  for (; i + 12 <= i1; i += 12) tile<3, NC, false>(i, j, k, a, lda, b, ldb, c, ldc, none);
  if (i + 8 <= i1) {
    tile<2, NC, false>(i, j, k, a, lda, b, ldb, c, ldc, none);
    i += 8;
  }
  if (i + 4 <= i1) {
    tile<1, NC, false>(i, j, k, a, lda, b, ldb, c, ldc, none);
    i += 4;
  }
  if (i < i1) tile<1, NC, true>(i, j, k, a, lda, b, ldb, c, ldc, first_lanes(i1 - i));
}

void column_block_any(int32_t nc, int32_t i0, int32_t i1, int32_t j, int32_t k, const double* a, int64_t lda,
                      const double* b, int64_t ldb, double* c, int64_t ldc) {
  switch (nc) {
    case 4: column_block<4>(i0, i1, j, k, a, lda, b, ldb, c, ldc); break;
    case 3: column_block<3>(i0, i1, j, k, a, lda, b, ldb, c, ldc); break;
    case 2: column_block<2>(i0, i1, j, k, a, lda, b, ldb, c, ldc); break;
    case 1: column_block<1>(i0, i1, j, k, a, lda, b, ldb, c, ldc); break;
    default: break;
  }
}

// C = 0 for an empty inner dimension (the tiles assume k ≥ 1): rows [first_row(j), m) of each column j.
template <typename FirstRow>
void zero_columns(int32_t m, int32_t n, double* c, int64_t ldc, FirstRow first_row) {
  for (int32_t j = 0; j < n; ++j) std::fill(c + first_row(j) + j * ldc, c + m + j * ldc, 0.0);
}

void gemm_nt_fma(int32_t m, int32_t n, int32_t k, const double* a, int64_t lda, const double* b, int64_t ldb, double* c,
                 int64_t ldc) {
  if (k < 1) return zero_columns(m, n, c, ldc, [](int32_t) { return 0; });
  for (int32_t j = 0; j < n; j += 4) column_block_any(std::min<int32_t>(4, n - j), 0, m, j, k, a, lda, b, ldb, c, ldc);
}

// The lower triangle: each block of (up to) four columns from its diagonal down. The block on the
// diagonal is computed whole into a scratch and only its lower part copied (its entries are the same
// chains as gemm_nt's).
void syrk_lower_fma(int32_t n, int32_t k, const double* a, int64_t lda, double* c, int64_t ldc) {
  if (k < 1) return zero_columns(n, n, c, ldc, [](int32_t j) { return j; });  // the lower triangle
  for (int32_t j = 0; j < n; j += 4) {
    const int32_t nc = std::min<int32_t>(4, n - j);
    double block[16];
    column_block_any(nc, 0, nc, 0, k, a + j, lda, a + j, lda, block, 4);
    for (int32_t t = 0; t < nc; ++t)
      for (int32_t r = t; r < nc; ++r) c[(j + r) + (j + t) * ldc] = block[r + 4 * t];
    column_block_any(nc, j + nc, n, j, k, a, lda, a, lda, c, ldc);
  }
}

// B = B L⁻ᵀ, row by row independent: x_j = (b_j − Σ_{q<j} x_q L(j, q)) / L(j, j), the sum subtracted term
// by term in increasing q (fnmadd: one rounding each). Blocked like the product: RV vectors of rows times
// NC columns j0 .. j0+NC−1 at a time, the last vector partial when MASKED. The block's accumulators start
// at b and take the terms of the columns solved before it (q < j0) as a product tile does (RV loads and NC
// broadcasts per RV·NC fused multiply-adds), then the terms inside the block in order, each column divided
// as soon as its sum is complete: every entry is the same chain as solved column by column, so the result
// does not depend on the row blocking (column by column, the loop waits on one dependent chain per row
// vector and on a load per fused multiply-add).
template <int RV, int NC, bool MASKED>
__attribute__((always_inline)) inline void solve_tile(int32_t i, int32_t j0, const double* l, int64_t ldl, double* b,
                                                      int64_t ldb, __m256i mask) {
  __m256d acc[RV][NC];
  for (int t = 0; t < NC; ++t)
    for (int r = 0; r < RV; ++r) {
      const double* bj = b + i + 4 * r + (j0 + t) * ldb;
      acc[r][t] = (MASKED && r == RV - 1) ? _mm256_maskload_pd(bj, mask) : _mm256_loadu_pd(bj);
    }
  for (int32_t q = 0; q < j0; ++q) {
    const double* bq = b + i + q * ldb;
    __m256d xv[RV];
    for (int r = 0; r < RV; ++r)
      xv[r] = (MASKED && r == RV - 1) ? _mm256_maskload_pd(bq + 4 * r, mask) : _mm256_loadu_pd(bq + 4 * r);
    for (int t = 0; t < NC; ++t) {
      const __m256d lq = _mm256_broadcast_sd(l + (j0 + t) + q * ldl);
      for (int r = 0; r < RV; ++r) acc[r][t] = _mm256_fnmadd_pd(xv[r], lq, acc[r][t]);
    }
  }
  for (int t = 0; t < NC; ++t) {
    for (int u = 0; u < t; ++u) {
      const __m256d lq = _mm256_broadcast_sd(l + (j0 + t) + (j0 + u) * ldl);
      for (int r = 0; r < RV; ++r) acc[r][t] = _mm256_fnmadd_pd(acc[r][u], lq, acc[r][t]);
    }
    const __m256d d = _mm256_broadcast_sd(l + (j0 + t) + (j0 + t) * ldl);
    for (int r = 0; r < RV; ++r) acc[r][t] = _mm256_div_pd(acc[r][t], d);
  }
  for (int t = 0; t < NC; ++t)
    for (int r = 0; r < RV; ++r) {
      double* bj = b + i + 4 * r + (j0 + t) * ldb;
      if (MASKED && r == RV - 1) _mm256_maskstore_pd(bj, mask, acc[r][t]);
      else _mm256_storeu_pd(bj, acc[r][t]);
    }
}

// Rows i .. i+4·RV−1 (the last vector partial when MASKED), all n columns, four at a time.
template <int RV, bool MASKED>
void solve_rows(int32_t i, int32_t n, const double* l, int64_t ldl, double* b, int64_t ldb, __m256i mask) {
  int32_t j = 0;
  for (; j + 4 <= n; j += 4) solve_tile<RV, 4, MASKED>(i, j, l, ldl, b, ldb, mask);
  switch (n - j) {
    case 3: solve_tile<RV, 3, MASKED>(i, j, l, ldl, b, ldb, mask); break;
    case 2: solve_tile<RV, 2, MASKED>(i, j, l, ldl, b, ldb, mask); break;
    case 1: solve_tile<RV, 1, MASKED>(i, j, l, ldl, b, ldb, mask); break;
    default: break;
  }
}

void solve_right_lower_transposed_fma(int32_t m, int32_t n, const double* l, int64_t ldl, double* b, int64_t ldb) {
  const __m256i none = _mm256_setzero_si256();
  int32_t i = 0;
  for (; i + 12 <= m; i += 12) solve_rows<3, false>(i, n, l, ldl, b, ldb, none);
  if (i + 8 <= m) {
    solve_rows<2, false>(i, n, l, ldl, b, ldb, none);
    i += 8;
  }
  if (i + 4 <= m) {
    solve_rows<1, false>(i, n, l, ldl, b, ldb, none);
    i += 4;
  }
  if (i < m) solve_rows<1, true>(i, n, l, ldl, b, ldb, first_lanes(m - i));
}

// y[rows[q]] −= blocks[q] · x, each column of the result one vector: y_j − L₀ x₀ⱼ − L₁ x₁ⱼ − L₂ x₂ⱼ by three
// fused multiply-subtracts (the four lanes hold a column's three rows and one spare). A block's last
// column is read with a mask (the array may end there); the new columns are stored in order, the first
// two as whole vectors, whose spare lane lands on the next column and is overwritten by its store, the
// last by halves so nothing past the block is written.
void subtract_block_products_fma(int32_t count, const int32_t* rows, const double* blocks, const double* x,
                                 double* y) {
  const __m256i three = first_lanes(3);
  __m256d xb[3][3];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) xb[r][c] = _mm256_broadcast_sd(x + r + 3 * c);
  for (int32_t q = 0; q < count; ++q) {
    const double* l = blocks + 9 * static_cast<int64_t>(q);
    double* yb = y + 9 * static_cast<int64_t>(rows[q]);
    const __m256d l0 = _mm256_loadu_pd(l), l1 = _mm256_loadu_pd(l + 3), l2 = _mm256_maskload_pd(l + 6, three);
    __m256d out[3];
    for (int c = 0; c < 3; ++c) {
      __m256d v = c < 2 ? _mm256_loadu_pd(yb + 3 * c) : _mm256_maskload_pd(yb + 6, three);
      v = _mm256_fnmadd_pd(l0, xb[0][c], v);
      v = _mm256_fnmadd_pd(l1, xb[1][c], v);
      out[c] = _mm256_fnmadd_pd(l2, xb[2][c], v);
    }
    _mm256_storeu_pd(yb, out[0]);
    _mm256_storeu_pd(yb + 3, out[1]);
    _mm_storeu_pd(yb + 6, _mm256_castpd256_pd128(out[2]));
    _mm_store_sd(yb + 8, _mm256_extractf128_pd(out[2], 1));
  }
}

// The four lanes' sum, in a fixed order: (l0 + l2) + (l1 + l3).
inline double lane_sum(__m256d v) {
  const __m128d pair = _mm_add_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd(v, 1));
  return _mm_cvtsd_f64(_mm_add_sd(pair, _mm_unpackhi_pd(pair, pair)));
}

// Σ_{i < count} a[i] b[i]: four lanes, each a chain over its indices, the last vector masked, then lane_sum.
inline double dot(int32_t count, const double* a, const double* b) {
  __m256d acc = _mm256_setzero_pd();
  int32_t i = 0;
  for (; i + 4 <= count; i += 4) acc = _mm256_fmadd_pd(_mm256_loadu_pd(a + i), _mm256_loadu_pd(b + i), acc);
  if (i < count) {
    const __m256i mask = first_lanes(count - i);
    acc = _mm256_fmadd_pd(_mm256_maskload_pd(a + i, mask), _mm256_maskload_pd(b + i, mask), acc);
  }
  return lane_sum(acc);
}

// y = L₁₁⁻¹ y by columns (y_j /= L_jj, then the column below it times y_j leaves the later entries), then
// t = L₂₁ y: per vector of four rows one chain over the columns, sixteen rows at a time.
void panel_forward_fma(int32_t n, int32_t m, const double* l, int64_t ld, double* y, double* t) {
  for (int32_t j = 0; j < n; ++j) {
    const double* column = l + j * ld;
    const double yj = y[j] / column[j];
    y[j] = yj;
    const __m256d v = _mm256_set1_pd(yj);
    int32_t i = j + 1;
    for (; i + 4 <= n; i += 4)
      _mm256_storeu_pd(y + i, _mm256_fnmadd_pd(_mm256_loadu_pd(column + i), v, _mm256_loadu_pd(y + i)));
    for (; i < n; ++i) y[i] = std::fma(-column[i], yj, y[i]);
  }
  if (n == 0) {
    std::fill(t, t + m, 0.0);
    return;
  }
  const double* below = l + n;
  int32_t i = 0;
  for (; i + 16 <= m; i += 16) {
    __m256d acc[4];
    for (int r = 0; r < 4; ++r) acc[r] = _mm256_setzero_pd();
    for (int32_t j = 0; j < n; ++j) {
      const __m256d v = _mm256_broadcast_sd(y + j);
      for (int r = 0; r < 4; ++r) acc[r] = _mm256_fmadd_pd(_mm256_loadu_pd(below + i + 4 * r + j * ld), v, acc[r]);
    }
    for (int r = 0; r < 4; ++r) _mm256_storeu_pd(t + i + 4 * r, acc[r]);
  }
  for (; i < m; i += 4) {
    const __m256i mask = first_lanes(std::min<int32_t>(4, m - i));
    __m256d acc = _mm256_setzero_pd();
    for (int32_t j = 0; j < n; ++j)
      acc = _mm256_fmadd_pd(_mm256_maskload_pd(below + i + j * ld, mask), _mm256_broadcast_sd(y + j), acc);
    _mm256_maskstore_pd(t + i, mask, acc);
  }
}

// y −= L₂₁ᵀ t, one dot product per column (contiguous), then y = L₁₁⁻ᵀ y from the last entry up, each a
// dot product of the column below the diagonal with the entries already solved.
void panel_backward_fma(int32_t n, int32_t m, const double* l, int64_t ld, const double* t, double* y) {
  for (int32_t j = 0; j < n; ++j) y[j] -= dot(m, l + n + j * ld, t);
  for (int32_t j = n - 1; j >= 0; --j) {
    const double* column = l + j * ld;
    y[j] = (y[j] - dot(n - 1 - j, column + j + 1, y + j + 1)) / column[j];
  }
}

}  // namespace

// The Cholesky of a diagonal block stays Eigen's (one call per supernode, whatever the chunks).
void fill_fma(DenseKernels& k) {
  k.llt_lower = llt_lower;
  k.syrk_lower = syrk_lower_fma;
  k.gemm_nt = gemm_nt_fma;
  k.solve_right_lower_transposed = solve_right_lower_transposed_fma;
  k.subtract_block_products = subtract_block_products_fma;
  k.panel_forward = panel_forward_fma;
  k.panel_backward = panel_backward_fma;
}

}  // namespace pt::dense::avx2
