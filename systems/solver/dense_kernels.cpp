#include "systems/solver/dense_kernels.hpp"

#include <atomic>
#include <cstring>

#define PT_DENSE_BUILD baseline
#include "systems/solver/dense_kernels_impl.inc"

namespace pt {

#if defined(PT_HAVE_AVX2_KERNELS)
namespace dense::avx2 {
void fill_fma(DenseKernels& k);  // dense_kernels_avx2.cpp
}
#endif
#if defined(PT_HAVE_AVX512_KERNELS)
namespace dense::avx512 {
void fill_products(DenseKernels& k);  // dense_kernels_avx512.cpp
}
#endif

const DenseKernels& baseline_dense_kernels() {
  static const DenseKernels k = [] {
    DenseKernels d{};
    d.name = "baseline";
    d.syrk_lower = dense::baseline::syrk_lower;
    d.gemm_nt = dense::baseline::gemm_nt;
    d.llt_lower = dense::baseline::llt_lower;
    d.solve_right_lower_transposed = dense::baseline::solve_right_lower_transposed;
    d.subtract_block_products = dense::baseline::subtract_block_products;
    d.panel_forward = dense::baseline::panel_forward;
    d.panel_backward = dense::baseline::panel_backward;
    return d;
  }();
  return k;
}

const DenseKernels* avx2_dense_kernels() {
#if defined(PT_HAVE_AVX2_KERNELS)
  static const DenseKernels* k = []() -> const DenseKernels* {
    __builtin_cpu_init();
    if (!__builtin_cpu_supports("avx2") || !__builtin_cpu_supports("fma")) return nullptr;
    static DenseKernels d{};
    d.name = "avx2+fma";
    dense::avx2::fill_fma(d);
    return &d;
  }();
  return k;
#else
  return nullptr;
#endif
}

const DenseKernels* avx512_dense_kernels() {
#if defined(PT_HAVE_AVX2_KERNELS) && defined(PT_HAVE_AVX512_KERNELS)
  static const DenseKernels* k = []() -> const DenseKernels* {
    const DenseKernels* avx2 = avx2_dense_kernels();
    if (!avx2 || !__builtin_cpu_supports("avx512f")) return nullptr;
    static DenseKernels d = *avx2;
    d.name = "avx512+avx2+fma";
    dense::avx512::fill_products(d);
    return &d;
  }();
  return k;
#else
  return nullptr;
#endif
}

namespace {

const DenseKernels& kernels_for(DenseKernelChoice choice) {
  if (choice == DenseKernelChoice::Baseline) return baseline_dense_kernels();
  if (const DenseKernels* a = avx512_dense_kernels(); a && choice == DenseKernelChoice::Fastest) return *a;
  if (const DenseKernels* a = avx2_dense_kernels()) return *a;
  return baseline_dense_kernels();
}

// The chosen build; null until select_dense_kernels (the fastest). Read once per factor column, so a plain
// atomic pointer rather than a lock.
std::atomic<const DenseKernels*> g_selected{nullptr};

}  // namespace

bool dense_kernel_choice_from_name(const char* name, DenseKernelChoice& choice) {
  if (!name) return false;
  if (std::strcmp(name, "avx2") == 0) choice = DenseKernelChoice::Avx2;
  else if (std::strcmp(name, "baseline") == 0) choice = DenseKernelChoice::Baseline;
  else return false;
  return true;
}

void select_dense_kernels(DenseKernelChoice choice) {
  g_selected.store(&kernels_for(choice), std::memory_order_release);
}

const DenseKernels& dense_kernels() {
  if (const DenseKernels* k = g_selected.load(std::memory_order_acquire)) return *k;
  static const DenseKernels& fastest = kernels_for(DenseKernelChoice::Fastest);
  return fastest;
}

}  // namespace pt
