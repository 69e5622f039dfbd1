// Experiment (bench/results/2026-11-23-11-notes.txt; not built by CMake): would 512-bit products beat the engine's AVX2 panel
// product on a host that has AVX-512? The tile below is the AVX2 kernel's (systems/dense_kernels_avx2.cpp)
// with eight-lane vectors: every entry one fused multiply-add chain over the inner index in increasing
// order, so its results are bit-identical to the AVX2 kernel's (checked below). Shapes are the
// supernodal updates' (m rows of a chunk, n = 96 columns of the target, k the descendant's width).
// From the repository root, after `make build` (-O3 as CMake's Release build compiles the kernels):
//   g++ -O3 -std=c++20 -mavx512f -mfma -I. -I/usr/include/eigen3 bench/experiments/avx512_tile.cpp \
//     build/libpt_integrate.a -o /tmp/avx512_tile && /tmp/avx512_tile
// Measured 2026-11-23 (Intel Xeon, one core, best of 20 × 200 calls), GFlop/s, AVX2 kernel | 512-bit tiles:
//   m=48  n=96 k=24:  52.7 | 24x8 74.9, 16x4 64.7, 32x4 (covers 32 of the 48 rows), 16x6 70.7, 8x8 67.9
//   m=96  n=96 k=48:  53.8 | 24x8 80.4, 16x4 63.9, 32x4 71.6, 16x6 67.9, 8x8 65.3
//   m=192 n=96 k=96:  48.6 | 24x8 74.6, 16x4 53.6, 32x4 51.2, 16x6 64.1, 8x8 65.7
//   m=384 n=96 k=192: 42.3 | 24x8 69.5, 16x4 43.3, 32x4 45.5, 16x6 49.6, 8x8 48.4
// So the engine has the 24x8 tile (systems/dense_kernels_avx512.cpp). Compiled at -O2 instead, GCC 12 does
// not unroll the tiles' loops and keeps the accumulators on the stack: 24x8 then ran 26-30 GFlop/s, which
// first looked like "this core runs 512-bit products no faster" (notes 2026-11-23-11, §2).
#include "systems/dense_kernels.hpp"

#include <immintrin.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <random>
#include <vector>

namespace {

template <int RV, int NC>
__attribute__((always_inline)) inline void tile(int32_t i, int32_t j, int32_t k, const double* a, int64_t lda,
                                                const double* b, int64_t ldb, double* c, int64_t ldc) {
  __m512d acc[RV][NC];
  for (int r = 0; r < RV; ++r)
    for (int t = 0; t < NC; ++t) acc[r][t] = _mm512_setzero_pd();
  if (k < 1) __builtin_unreachable();
  for (int32_t q = 0; q < k; ++q) {
    const double* aq = a + i + q * lda;
    const double* bq = b + j + q * ldb;
    __m512d av[RV];
    for (int r = 0; r < RV; ++r) av[r] = _mm512_loadu_pd(aq + 8 * r);
    for (int t = 0; t < NC; ++t) {
      const __m512d bt = _mm512_set1_pd(bq[t]);
      for (int r = 0; r < RV; ++r) acc[r][t] = _mm512_fmadd_pd(av[r], bt, acc[r][t]);
    }
  }
  for (int t = 0; t < NC; ++t)
    for (int r = 0; r < RV; ++r) _mm512_storeu_pd(c + i + 8 * r + (j + t) * ldc, acc[r][t]);
}

// C = A Bᵀ for m a multiple of 8·RV and n of NC (the shapes below are).
template <int RV, int NC>
void gemm_nt_512(int32_t m, int32_t n, int32_t k, const double* a, int64_t lda, const double* b, int64_t ldb,
                 double* c, int64_t ldc) {
  for (int32_t j = 0; j < n; j += NC)
    for (int32_t i = 0; i + 8 * RV <= m; i += 8 * RV) tile<RV, NC>(i, j, k, a, lda, b, ldb, c, ldc);
}

}  // namespace

int main() {
  const pt::DenseKernels* avx2 = pt::avx2_dense_kernels();
  if (!avx2) {
    std::printf("no AVX2 + FMA kernels on this CPU or build\n");
    return 1;
  }
  for (int32_t size : {24, 48, 96, 192}) {
    const int32_t m = 2 * size, n = 96, k = size;
    const int64_t lda = m + 7;
    std::vector<double> a(lda * k), b(n * k), reference(int64_t{m} * n), c(int64_t{m} * n);
    std::mt19937 rng(1);
    std::uniform_real_distribution<double> u(-1, 1);
    for (double& x : a) x = u(rng);
    for (double& x : b) x = u(rng);
    auto rate = [&](auto product, std::vector<double>& out) {
      double best = 1e9;
      for (int round = 0; round < 20; ++round) {
        const auto start = std::chrono::steady_clock::now();
        for (int call = 0; call < 200; ++call) product(m, n, k, a.data(), lda, b.data(), n, out.data(), m);
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / 200;
        best = std::min(best, s);
      }
      return 2.0 * m * n * k / best / 1e9;
    };
    const double kernel = rate(avx2->gemm_nt, reference);
    const double t24x8 = rate(gemm_nt_512<3, 8>, c);
    const bool same = std::memcmp(c.data(), reference.data(), c.size() * sizeof(double)) == 0;
    const double t16x4 = rate(gemm_nt_512<2, 4>, c), t32x4 = rate(gemm_nt_512<4, 4>, c);
    const double t16x6 = rate(gemm_nt_512<2, 6>, c), t8x8 = rate(gemm_nt_512<1, 8>, c);
    std::printf("m=%d n=%d k=%d: %.1f | 24x8 %.1f (bit-identical: %s), 16x4 %.1f, 32x4 %.1f, 16x6 %.1f, 8x8 %.1f\n", m,
                n, k, kernel, t24x8, same ? "yes" : "NO", t16x4, t32x4, t16x6, t8x8);
  }
}
