// The carving system (paper §6, docs/architecture.md "Details"; issue 5 target: one segment at the default
// resolution ≤ 50 µs). A segment is ~5 mm at 0.1 mm per pixel (about 50 path pixels), σ = 0.1 mm, ω = 0.5.
#include "systems/carving/carving.hpp"

#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

using namespace pt;

namespace {

DetailParams a4_params() {
  DetailParams p;
  p.origin = Vec2(0, 0);
  p.pixel_size = 1e-4;
  p.width = 2100;
  p.height = 2970;
  p.sigma = 1e-4;
  p.omega = 0.5;
  return p;
}

FiberField a4_fiber() {
  FiberField f;
  f.seed = 1;
  f.origin = Vec2(0, 0);
  f.pixel_size = 1e-4;
  return f;
}

// 64 segments of 5 mm in all directions over the sheet.
std::vector<std::array<Vec2, 2>> segments() {
  std::vector<std::array<Vec2, 2>> s;
  for (int k = 0; k < 64; ++k) {
    const double angle = 0.37 * k;
    const Vec2 a(0.02 + 0.0025 * k, 0.03 + 0.0035 * k);
    s.push_back({a, a + 0.005 * Vec2(std::cos(angle), std::sin(angle))});
  }
  return s;
}

// Everything carve_new_segments does for one new segment: the greedy path, the detail points and the
// band's side labels (tiles already allocated: steady state of a propagating tear's neighbourhood).
void BM_CarveSegment(benchmark::State& state) {
  const DetailParams p = a4_params();
  const FiberField f = a4_fiber();
  const auto segs = segments();
  CarveState carve;
  std::vector<Tear> tears(1);
  tears[0].id = 0;
  size_t k = 0;
  int64_t pixels = 0;
  for (auto _ : state) {
    Tear& t = tears[0];
    t.tips.assign(segs[k].begin(), segs[k].end());
    t.detail.clear();
    t.carved_segments = 0;
    carve_new_segments(f, p, tears, carve);
    pixels += static_cast<int64_t>(t.detail.size());
    benchmark::DoNotOptimize(t.detail.data());
    k = (k + 1) % segs.size();
  }
  state.counters["path_px"] = benchmark::Counter(static_cast<double>(pixels), benchmark::Counter::kAvgIterations);
  state.counters["label_kB"] = static_cast<double>(bytes_used(carve)) / 1024.0;
}
BENCHMARK(BM_CarveSegment)->Unit(benchmark::kMicrosecond);

// The greedy walk alone (eq. 7 evaluations dominate).
void BM_DetailPath(benchmark::State& state) {
  const DetailParams p = a4_params();
  const FiberField f = a4_fiber();
  const auto segs = segments();
  std::vector<Pixel> path;
  size_t k = 0;
  for (auto _ : state) {
    detail_path(f, p, segs[k][0], segs[k][1], path);
    benchmark::DoNotOptimize(path.data());
    k = (k + 1) % segs.size();
  }
}
BENCHMARK(BM_DetailPath)->Unit(benchmark::kMicrosecond);

// One texel of T_fiber (5 octaves of hashed Perlin noise).
void BM_FiberTexel(benchmark::State& state) {
  const FiberField f = a4_fiber();
  int32_t i = 0;
  double sum = 0;
  for (auto _ : state) {
    sum += fiber_texel(f, i, i * 3 + 7);
    i = (i + 1) & 2047;
  }
  benchmark::DoNotOptimize(sum);
}
BENCHMARK(BM_FiberTexel)->Unit(benchmark::kNanosecond);

}  // namespace
