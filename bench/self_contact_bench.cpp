// The self-contact pass (systems/physics/self_contact.hpp) of one substep at 1 000 and 10 000 triangles: an
// A4 sheet folded in half with its top half's layer 1 mm above the bottom one and falling onto it at
// 0.3 m/s (1 mm per 300 Hz substep: repulsions, collisions and their passes), and the same sheet lying flat
// and still (nothing touches: the broad phase and the pairs' boxes only). A frame is 10 substeps. The
// broad phase keeps its pairs between iterations (the same substep again), so after the first this times
// a substep its kept pairs serve; BM_FrameSelfContact (frame_bench.cpp) has whole runs, queries included.
#include "bench_scenes.hpp"

#include "engine/sheet_builder.hpp"
#include "systems/physics/self_contact.hpp"

#include <benchmark/benchmark.h>

#include <oneapi/tbb/task_arena.h>

#include <cmath>

using namespace pt;

namespace {

struct ContactScene {
  Sheet sheet;
  std::vector<Vec3> x0, x1, v;
  std::vector<double> inverse_mass;
};

// folded: the pattern's top half (v > H/2) mirrored over v = H/2 and 1 mm above, rippled by 0.5 mm so
// the layers are not parallel planes, and falling 1 mm over the substep.
ContactScene contact_scene(int32_t triangles, bool folded) {
  ContactScene c;
  c.sheet = build_sheet(bench::a4_scene(triangles, false));
  const double H = 0.297, h = 1.0 / 300;
  const Vertices& V = c.sheet.verts;
  for (int32_t i = 0; i < V.size(); ++i) {
    const Vec2 r = V.rest[i];
    Vec3 x(r.x(), r.y(), 0), v = Vec3::Zero();
    if (folded) {
      const double ripple = 5e-4 * std::sin(60 * r.x()) * std::sin(40 * r.y());
      if (r.y() > H / 2) {
        const double over = r.y() - H / 2;  // the crease: a half circle of 1 mm between the layers
        const double angle = std::min(1.0, over / (M_PI * 5e-4)) * M_PI;
        x = over < M_PI * 5e-4 ? Vec3(r.x(), H / 2 + 5e-4 * std::sin(angle), 5e-4 * (1 - std::cos(angle)))
                               : Vec3(r.x(), H / 2 - (over - M_PI * 5e-4), 1e-3 + ripple);
        if (over >= M_PI * 5e-4) v = Vec3(0, 0, -0.3);
      } else {
        x.z() = 0.5 * ripple;
      }
    }
    c.x0.push_back(x);
    c.v.push_back(v);
    c.x1.push_back(x + h * v);
    c.inverse_mass.push_back(V.mass[i] > 0 ? 1 / V.mass[i] : 0);
  }
  return c;
}

void self_contact_substep(benchmark::State& state, bool folded) {
  const ContactScene c = contact_scene(static_cast<int32_t>(state.range(0)), folded);
  tbb::task_arena arena(2);
  SelfContactParams params;
  SelfContactBroadPhasePtr broad;
  SelfContactStats stats;
  for (auto _ : state) {
    std::vector<Vec3> x = c.x1, v = c.v;
    arena.execute([&] {
      stats = resolve_self_contact(params, c.sheet.tris.tri, c.sheet.verts.rest, c.x0, c.inverse_mass, broad, x, v);
    });
    benchmark::DoNotOptimize(x.data());
  }
  state.counters["triangles"] = c.sheet.tris.size();
  state.counters["proximities"] = static_cast<double>(stats.proximities);
  state.counters["collisions"] = static_cast<double>(stats.collisions);
  state.counters["zones"] = static_cast<double>(stats.zones);
}

void BM_SelfContactFolded(benchmark::State& state) { self_contact_substep(state, true); }
void BM_SelfContactFlat(benchmark::State& state) { self_contact_substep(state, false); }

}  // namespace

BENCHMARK(BM_SelfContactFolded)->Arg(1000)->Arg(10000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SelfContactFlat)->Arg(100)->Arg(1000)->Arg(10000)->Unit(benchmark::kMillisecond);
