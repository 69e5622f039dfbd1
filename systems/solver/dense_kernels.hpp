// Dense kernels of the block factorisations (systems/solver/block_ldlt.cpp): the supernodal path's panel
// products, diagonal block Cholesky and triangular solve below it, on column-major matrices given by
// pointer and leading dimension, and the column path's 3 × 3 block update. They are most of a big sheet's
// factorisation (a 10 000-triangle sheet: 0.57 GFlop per factorisation), and Debian builds for the x86-64
// baseline, whose SSE2 kernels reach 6–7 GFlop/s per core on this machine. So there are two builds, chosen
// once per process by what the CPU supports: the baseline one (Eigen, dense_kernels_impl.inc) and one
// compiled for AVX2 + FMA (dense_kernels_avx2.cpp: hand-written products and solve whose entries do not
// depend on how a panel is chunked, and Eigen's Cholesky compiled for AVX2), whose two products have a third,
// AVX-512 build giving the same bits. A process uses one of them throughout, so results stay bit-identical
// at any thread count; they differ between the baseline and the others by rounding (FMA).
#pragma once

#include <cstdint>

namespace pt {

struct DenseKernels {
  const char* name;
  // C = A Aᵀ on the lower triangle of C (n × n); A is n × k. The strict upper triangle is not written.
  void (*syrk_lower)(int32_t n, int32_t k, const double* a, int64_t lda, double* c, int64_t ldc);
  // C = A Bᵀ; A is m × k, B is n × k, C is m × n.
  void (*gemm_nt)(int32_t m, int32_t n, int32_t k, const double* a, int64_t lda, const double* b, int64_t ldb,
                  double* c, int64_t ldc);
  // In place: the lower triangle of A (n × n, symmetric positive definite) becomes L with A = L Lᵀ.
  // False when a pivot is not positive or the factor is not finite.
  bool (*llt_lower)(int32_t n, double* a, int64_t lda);
  // In place: B = B L⁻ᵀ, L the lower triangle of an n × n matrix, B m × n.
  void (*solve_right_lower_transposed)(int32_t m, int32_t n, const double* l, int64_t ldl, double* b, int64_t ldb);
  // The column factorisation's inner update (block_ldlt.cpp, factor_column): y[rows[q]] −= blocks[q] · x for
  // q < count, every matrix a 3 × 3 block of 9 column-major doubles. Most of a ~1 000-triangle frame.
  void (*subtract_block_products)(int32_t count, const int32_t* rows, const double* blocks, const double* x,
                                  double* y);
  // The supernodal solve at one panel (column-major, leading dimension ld: the n × n lower triangle L₁₁ on
  // top, the m rows L₂₁ below it). Forward: y = L₁₁⁻¹ y, then t = L₂₁ y. Backward: y = L₁₁⁻ᵀ (y − L₂₁ᵀ t).
  void (*panel_forward)(int32_t n, int32_t m, const double* l, int64_t ld, double* y, double* t);
  void (*panel_backward)(int32_t n, int32_t m, const double* l, int64_t ld, const double* t, double* y);
};

// Which build the factorisations use. Fastest: on a CPU with AVX-512F, the AVX2 + FMA build with its two
// products from dense_kernels_avx512.cpp (the same bits, faster); else the AVX2 + FMA build when the CPU has
// both; else the baseline. Avx2: the AVX2 + FMA build without the AVX-512 products (the baseline on a CPU
// without AVX2). Baseline: the portable Eigen build.
enum class DenseKernelChoice { Fastest, Avx2, Baseline };

// "avx2" → Avx2, "baseline" → Baseline; false for any other name. The command line and the benchmarks take
// the choice from PAPERTEAR_DENSE_KERNELS with this; the library reads no environment.
bool dense_kernel_choice_from_name(const char* name, DenseKernelChoice& choice);

// Chooses the build for the whole process (Fastest until then). A program calls it before any simulation
// runs: the factorisations read the kernels per panel, so one running during the call could mix two
// builds, and a factor's bits depend on the build.
void select_dense_kernels(DenseKernelChoice choice);

// The kernels this process uses now (select_dense_kernels).
const DenseKernels& dense_kernels();
// Each build on its own (tests, benchmarks); the pointers are null when this CPU or build lacks it.
const DenseKernels& baseline_dense_kernels();
const DenseKernels* avx2_dense_kernels();
const DenseKernels* avx512_dense_kernels();

}  // namespace pt
