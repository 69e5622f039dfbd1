// Picking a finger (issue 7: a pick <= 0.1 ms): an Embree ray cast against the deformed sheet, alone
// and with the refit the viewer does first when the sheet has moved since the last pick, at 100, 1 000
// and 10 000 triangles. The sheet is the benchmark A4 bent into a wave; the rays come from a camera
// above it through a grid of points on the sheet.
#include "bench_scenes.hpp"

#include "engine/picking.hpp"
#include "engine/sheet_builder.hpp"

#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

using namespace pt;

namespace {

Sheet wavy_sheet(int32_t triangles, double phase) {
  Sheet sh = build_sheet(bench::a4_scene(triangles));
  for (int32_t i = 0; i < sh.verts.size(); ++i) {
    const Vec2 r = sh.verts.rest[i];
    sh.verts.x[i] = Vec3(r.x(), r.y(), 0.02 * std::sin(30 * r.x() + phase) * (0.3 - r.y()));
  }
  return sh;
}

// Rays from an eye above the sheet through a 16 x 16 grid over its extent.
std::vector<std::pair<Vec3, Vec3>> grid_rays() {
  std::vector<std::pair<Vec3, Vec3>> rays;
  const Vec3 eye(0.105, 0.15, 0.5);
  for (int i = 0; i < 16; ++i)
    for (int j = 0; j < 16; ++j) {
      const Vec3 p(0.21 * (i + 0.5) / 16, 0.297 * (j + 0.5) / 16, 0.0);
      rays.push_back({eye, (p - eye).normalized()});
    }
  return rays;
}

void BM_Pick(benchmark::State& state) {
  const Sheet sh = wavy_sheet(static_cast<int32_t>(state.range(0)), 0.0);
  Picker picker;
  picker.update(sh);
  const auto rays = grid_rays();
  size_t k = 0, hits = 0;
  for (auto _ : state) {
    const auto& [o, d] = rays[k++ % rays.size()];
    const auto hit = picker.pick(o, d);
    hits += hit.has_value();
    benchmark::DoNotOptimize(hit);
  }
  state.counters["triangles"] = sh.tris.size();
  state.counters["hit_fraction"] = static_cast<double>(hits) / std::max<size_t>(1, k);
}
BENCHMARK(BM_Pick)->Arg(100)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

// Alternates the picker's scene between sheets a and b before each pick: what a click costs when the
// sheet changed since the last one.
void pick_after_each_update(benchmark::State& state, const Sheet& a, const Sheet& b) {
  Picker picker;
  picker.update(a);
  const int64_t rebuilds_before = picker.rebuilds();
  const auto rays = grid_rays();
  size_t k = 0, hits = 0;
  for (auto _ : state) {
    picker.update(k % 2 ? a : b);
    const auto& [o, d] = rays[k++ % rays.size()];
    const auto hit = picker.pick(o, d);
    hits += hit.has_value();
    benchmark::DoNotOptimize(hit);
  }
  state.counters["triangles"] = a.tris.size();
  state.counters["hit_fraction"] = static_cast<double>(hits) / std::max<size_t>(1, k);
  state.counters["rebuilds_per_pick"] =
      static_cast<double>(picker.rebuilds() - rebuilds_before) / std::max<size_t>(1, k);
}

// A click after a step: the sheet moved, so the picker refits its scene to the new positions.
void BM_PickAfterStep(benchmark::State& state) {
  const int32_t n = static_cast<int32_t>(state.range(0));
  pick_after_each_update(state, wavy_sheet(n, 0.0), wavy_sheet(n, 0.3));
}
BENCHMARK(BM_PickAfterStep)->Arg(100)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

// A click after a cut: the topology changed, so the picker rebuilds its scene.
void BM_PickAfterCut(benchmark::State& state) {
  const int32_t n = static_cast<int32_t>(state.range(0));
  const Sheet a = wavy_sheet(n, 0.0);
  Sheet b = wavy_sheet(n, 0.3);
  b.topology_version = a.topology_version + 1;
  pick_after_each_update(state, a, b);
}
BENCHMARK(BM_PickAfterCut)->Arg(100)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

}  // namespace
