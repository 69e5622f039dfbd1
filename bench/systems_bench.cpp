// One benchmark per geometric / tearing system (issues 4 and 6), at 100, 1 000 and 10 000 triangles:
// regions, candidates, clustering + propagation at a tip, remeshing (one cut). The sheet is an A4 with a
// notch, bent into a wave so the regions are not trivial, with a tear already cut from the notch.
#include "bench_scenes.hpp"

#include "engine/sheet_builder.hpp"
#include "systems/solver/block_ldlt.hpp"
#include "systems/tearing/candidates.hpp"
#include "systems/tearing/clustering.hpp"
#include "systems/tearing/material_force.hpp"
#include "systems/physics/membrane_forces.hpp"
#include "systems/tearing/propagation.hpp"
#include "systems/tearing/regions.hpp"
#include "systems/mesh/remeshing.hpp"
#include "systems/common/topology.hpp"

#include <benchmark/benchmark.h>

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/partitioner.h>
#include <oneapi/tbb/task_arena.h>

#include <algorithm>
#include <cmath>

using namespace pt;

namespace {

struct BentSheet {
  Sheet sheet;
  FiberField fiber;
  int32_t tip = -1;
};

BentSheet bent_sheet(int32_t triangles) {
  const Scenario s = bench::a4_scene(triangles);
  BentSheet b;
  b.sheet = build_sheet(s);
  b.fiber = make_fiber_field(s);
  Sheet& sh = b.sheet;
  for (int32_t i = 0; i < sh.verts.size(); ++i) {
    const Vec2 r = sh.verts.rest[i];
    sh.verts.x[i] = Vec3(r.x(), r.y(), 0.02 * std::sin(30 * r.x()) * (0.3 - r.y()));
  }
  // A tear from the notch apex (0.105, 0.28) 2 cm down.
  int32_t apex = 0;
  for (int32_t i = 0; i < sh.verts.size(); ++i)
    if ((sh.verts.rest[i] - Vec2(0.105, 0.28)).norm() < 1e-9) apex = i;
  const CutResult cut = cut_tear_segment(apex, Vec2(0.105, 0.26), Vec2::Zero(), 0, RemeshParams{}, sh);
  Tear t;
  t.id = 0;
  t.tips = {Vec2(0.105, 0.28), cut.end};
  sh.tears.push_back(t);
  sh.tips.push_back(Tip{cut.tip_vertex, 0, Vec2(0, -1)});
  b.tip = cut.tip_vertex;
  compute_membrane_forces(sh.verts.x, sh.tris.tri, sh.tris.rest_inv, sh.tris.rest_area, membrane_params(sh.material), 0,
                          sh.tris.size(), sh.tris.corner_force);
  return b;
}

void BM_Regions(benchmark::State& state) {
  BentSheet b = bent_sheet(static_cast<int32_t>(state.range(0)));
  Sheet& s = b.sheet;
  for (auto _ : state) {
    const RegionSummary r =
        classify_regions(s.verts.x, s.tris.tri, s.topo, RegionParams{}, s.tris.region, s.regions, s.verts.flags);
    benchmark::DoNotOptimize(r);
  }
  state.counters["triangles"] = s.tris.size();
  state.counters["triangles_per_s"] =
      benchmark::Counter(static_cast<double>(s.tris.size()) * state.iterations(), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Regions)->Arg(100)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

// The engine's call: over the boundary vertices, with the fiber cache.
void BM_Candidates(benchmark::State& state) {
  BentSheet b = bent_sheet(static_cast<int32_t>(state.range(0)));
  Sheet& s = b.sheet;
  classify_regions(s.verts.x, s.tris.tri, s.topo, RegionParams{}, s.tris.region, s.regions, s.verts.flags);
  std::vector<Candidate> out;
  FiberSampleCache cache;
  for (auto _ : state) {
    find_candidates(s.verts, s.topo.boundary_vertices, s.tips, s.fingers, s.tears, s.material, b.fiber, out, cache);
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["candidates"] = static_cast<double>(out.size());
}
BENCHMARK(BM_Candidates)->Arg(100)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

// Clustering (eq. 4–5) and the decision (eq. 6) at the tear tip: cost independent of the sheet size.
void BM_ClusterAndPropagate(benchmark::State& state) {
  BentSheet b = bent_sheet(static_cast<int32_t>(state.range(0)));
  const Sheet& s = b.sheet;
  PropagationParams pp;
  for (auto _ : state) {
    ForceClusters c;
    cluster_tip_forces(s.verts, s.tris, s.topo, b.tip, ClusterParams{}, c);
    const PropagationDecision d = decide_propagation(c, s.topo, s.verts.rest, b.tip, 1.0, pp);
    benchmark::DoNotOptimize(d);
  }
}
BENCHMARK(BM_ClusterAndPropagate)->Arg(100)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

// The crack driving force at the tip (tearing.direction = material_force): the J-integral over a 4 cm
// domain. Its cost grows with the triangles in the domain (counter), not with the sheet.
void BM_MaterialForce(benchmark::State& state) {
  BentSheet b = bent_sheet(static_cast<int32_t>(state.range(0)));
  const Sheet& s = b.sheet;
  const MembraneParams mp = membrane_params(s.material);
  DrivingForceScratch scratch;
  DrivingForce f;
  for (auto _ : state) {
    f = crack_driving_force(s.verts, s.tris, s.topo, b.tip, 0.04, mp, scratch);
    benchmark::DoNotOptimize(f);
  }
  state.counters["domain_triangles"] = f.triangles;
}
BENCHMARK(BM_MaterialForce)->Arg(100)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

// The engine's arrays have spare capacity after their first growth (amortised push_back); a copy has none,
// and its first push_back would time a reallocation of every array instead of the cut.
void reserve_for_cuts(Sheet& sheet) {
  auto spare = [](auto& array, size_t extra) { array.reserve(array.size() + extra); };
  Triangles& t = sheet.tris;
  spare(t.tri, 256), spare(t.rest_inv, 256), spare(t.rest_area, 256), spare(t.corner_force, 256);
  spare(t.region, 256), spare(t.piece, 256), spare(t.side, 256);
  Vertices& v = sheet.verts;
  spare(v.x, 256), spare(v.v, 256), spare(v.force, 256), spare(v.rest, 256), spare(v.mass, 256);
  spare(v.flags, 256), spare(v.tear, 256);
  Topology& topo = sheet.topo;
  spare(topo.fans, 256), spare(topo.vt_tri, 2048);
  spare(topo.boundary_next, 256), spare(topo.boundary_prev, 256);
  spare(topo.neighbor, 256), spare(topo.edge_hinge, 256), spare(topo.hinges, 256);
}

// One 5 mm cut from the tip, on a fresh copy each time (the copy and its destruction are not timed).
// Includes the local topology refresh at its end. On finer meshes the 5 mm cross more triangles.
void BM_RemeshOneCut(benchmark::State& state) {
  BentSheet b = bent_sheet(static_cast<int32_t>(state.range(0)));
  const Vec2 from = b.sheet.verts.rest[b.tip];
  for (auto _ : state) {
    state.PauseTiming();
    Sheet copy = b.sheet;
    reserve_for_cuts(copy);
    state.ResumeTiming();
    const CutResult r = cut_tear_segment(b.tip, from + Vec2(0.001, -0.005), Vec2(0, -1), 0, RemeshParams{}, copy);
    benchmark::DoNotOptimize(r);
    state.PauseTiming();
    copy = Sheet{};
    state.ResumeTiming();
  }
}
BENCHMARK(BM_RemeshOneCut)->Arg(100)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

// A tear advancing from the tip by steps of 0.7 mean edge length, one cut per iteration, as the engine cuts
// it: the local change per cut is the same at every resolution, so the time per cut should not grow with
// the sheet (issue 3). The sheet is put back (not timed) before the tip nears the bottom edge.
// With `cold_caches`, 4 MB are read and written before every cut (not timed), as the frame's physics does
// with the solver's arrays between two tearing steps: the gap between the two is what a cut in a frame
// pays for cold code and data, not for more work.
void tear_advance(benchmark::State& state, bool cold_caches) {
  BentSheet b = bent_sheet(static_cast<int32_t>(state.range(0)));
  const double edge = std::sqrt(4 / std::sqrt(3.0) * total_rest_area(b.sheet.tris) / b.sheet.tris.size());
  const Vec2 direction = Vec2(0.1, -1).normalized();
  Sheet sheet = b.sheet;
  reserve_for_cuts(sheet);
  int32_t tip = b.tip;
  int64_t cuts = 0;
  std::vector<double> other(cold_caches ? 512 * 1024 : 0, 1.0);
  for (auto _ : state) {
    const bool restart = tip < 0 || sheet.verts.rest[tip].y() < 0.1;
    if (restart || cold_caches) {
      state.PauseTiming();
      if (restart) {
        sheet = b.sheet;
        reserve_for_cuts(sheet);
        tip = b.tip;
      }
      for (double& x : other) x = x * 0.5 + 0.5;
      benchmark::DoNotOptimize(other.data());
      state.ResumeTiming();
    }
    const Vec2 from = sheet.verts.rest[tip];
    const CutResult r = cut_tear_segment(tip, from + 0.7 * edge * direction, direction, 0, RemeshParams{}, sheet);
    tip = r.cut && !r.reached_boundary ? r.tip_vertex : -1;
    cuts += r.cut ? 1 : 0;
  }
  state.counters["edge_mm"] = 1e3 * edge;
  state.counters["cut_fraction"] = static_cast<double>(cuts) / static_cast<double>(state.iterations());
}
void BM_TearAdvance(benchmark::State& state) { tear_advance(state, false); }
void BM_TearAdvanceColdCache(benchmark::State& state) { tear_advance(state, true); }
BENCHMARK(BM_TearAdvance)->Arg(100)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_TearAdvanceColdCache)->Arg(100)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

}  // namespace

// The A4 sheet's matrix: keys, values and the vertices' rest coordinates.
struct SheetMatrix {
  int32_t n = 0;
  std::vector<std::pair<int32_t, int32_t>> keys;
  std::vector<Mat3> values;
  std::vector<Vec2> coordinates;
};

SheetMatrix sheet_matrix(int32_t triangles) {
  const Sheet sheet = build_sheet(bench::a4_scene(triangles, false));
  const int32_t n = sheet.verts.size();
  std::vector<std::pair<int32_t, int32_t>> keys;
  for (int32_t v = 0; v < n; ++v) keys.emplace_back(v, v);
  for (const Tri& t : sheet.tris.tri)
    for (int32_t a : t)
      for (int32_t b : t)
        if (a != b) keys.emplace_back(a, b);
  for (const Hinge& h : sheet.topo.hinges)
    for (int32_t a : h.v)
      for (int32_t b : h.v)
        if (a != b) keys.emplace_back(a, b);
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  std::vector<Mat3> values(keys.size());
  std::vector<double> row_sum(n, 0.0);
  for (size_t b = 0; b < keys.size(); ++b) {
    const auto [r, c] = keys[b];
    const double w = 1.0 / (1 + std::abs(r - c) % 7);  // symmetric in (r, c)
    values[b] = (r == c) ? Mat3(Mat3::Zero()) : Mat3(Mat3::Constant(-w) + Mat3::Identity() * w);
    row_sum[r] += 3 * w;
  }
  for (size_t b = 0; b < keys.size(); ++b)
    if (keys[b].first == keys[b].second) values[b] = Mat3::Identity() * (row_sum[keys[b].first] + 1e-3);
  std::vector<Vec2> coordinates(sheet.verts.rest.begin(), sheet.verts.rest.end());
  return {n, std::move(keys), std::move(values), std::move(coordinates)};
}

// A range runner over oneTBB for the calls run inside a task arena of `threads` (serial at 1).
RangeRunner tbb_runner(int32_t threads) {
  return [threads](int32_t count, int32_t grain, const RangeTask& task) {
    if (threads <= 1 || count <= 1) return task(0, count);
    tbb::parallel_for(
        tbb::blocked_range<int32_t>(0, count, std::max(1, grain)),
        [&](const tbb::blocked_range<int32_t>& r) { task(r.begin(), r.end()); }, tbb::simple_partitioner());
  };
}

// One numeric factorisation of the implicit integrator's matrix pattern (every vertex free, a block per
// pair of vertices sharing a triangle or a hinge) with diagonally dominant SPD values, at 1 and 2
// threads: the kernel that dominates a physics frame. Counters: fill (blocks of L), block updates and
// GFlop/s (54 flops per 3x3 block update).
void BM_BlockLdltFactor(benchmark::State& state) {
  const SheetMatrix m = sheet_matrix(static_cast<int32_t>(state.range(0)));
  const int32_t n = m.n, threads = static_cast<int32_t>(state.range(1));
  const auto& values = m.values;
  BlockLdlt ldlt;
  analyze_block_ldlt(n, m.keys, BlockLdltParams{}, ldlt, m.coordinates);
  tbb::task_arena arena(threads);
  const RangeRunner run = tbb_runner(threads);
  for (auto _ : state) {
    bool ok = false;
    arena.execute([&] { ok = factorize_block_ldlt(values, run, ldlt); });
    if (!ok) state.SkipWithError("factorisation refused");
  }
  state.counters["vertices"] = n;
  state.counters["fill_blocks"] = static_cast<double>(block_ldlt_fill(ldlt));
  state.counters["block_updates"] = static_cast<double>(ldlt.block_updates);
  state.counters["gflops"] = benchmark::Counter(54e-9 * static_cast<double>(ldlt.block_updates) * state.iterations(),
                                                benchmark::Counter::kIsRate);
}
BENCHMARK(BM_BlockLdltFactor)
    ->ArgsProduct({{100, 1000, 10000}, {1, 2}})
    ->ArgNames({"triangles", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The symbolic analysis that precedes it, once per structure (after every cut of a tear): orderings
// (AMD, and nested dissection compared with it, concurrently on two threads), elimination tree, patterns,
// supernodes.
void BM_BlockLdltAnalyze(benchmark::State& state) {
  const SheetMatrix m = sheet_matrix(static_cast<int32_t>(state.range(0)));
  const int32_t threads = static_cast<int32_t>(state.range(1));
  BlockLdlt ldlt;
  tbb::task_arena arena(threads);
  const RangeRunner run = tbb_runner(threads);
  for (auto _ : state)
    arena.execute([&] { analyze_block_ldlt(m.n, m.keys, BlockLdltParams{}, ldlt, m.coordinates, run); });
  state.counters["vertices"] = m.n;
}
BENCHMARK(BM_BlockLdltAnalyze)
    ->ArgsProduct({{1000, 10000}, {1, 2}})
    ->ArgNames({"triangles", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
