// papertear-memory: bytes per sheet (issue 5, docs/memory.md): the sheet's arrays (pt::sheet_bytes) and
// the carving label map (pt::bytes_used), with no tear and with a tear of a given length.
//
//   papertear-memory SCENARIO [--tear-cm L] [--frames N]
//
// 1. The scenario's sheet before any frame (no tear).
// 2. The same sheet simulated until its longest coarse tear reaches L cm (or the frames end): the real
//    sheet arrays and label map of a torn sheet.
// 3. The default texture frame of that sheet with one synthetic tear of exactly L cm carved into an empty
//    label map (5 mm coarse segments, ±1 mm zigzag, from the middle of the sheet's bounding box
//    downwards), so the label-map cost of L cm is independent of how far the physics tore.
// The fiber field is procedural (a FiberField struct, sizeof below); no full-resolution texture is held.
#include "engine/batch.hpp"
#include "engine/scenario.hpp"
#include "engine/simulation.hpp"
#include "engine/simulation_internals.hpp"
#include "systems/carving/carving.hpp"
#include "systems/tearing/fiber_field.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

namespace {

double longest_tear(const pt::Sheet& s) {
  double best = 0;
  for (const pt::Tear& t : s.tears) {
    double l = 0;
    for (size_t k = 1; k < t.tips.size(); ++k) l += (t.tips[k] - t.tips[k - 1]).norm();
    best = std::max(best, l);
  }
  return best;
}

void report(const char* what, const pt::Simulation& sim) {
  const pt::Sheet& s = sim.sheet();
  const size_t sheet = pt::sheet_bytes(s);
  const int64_t carve = pt::bytes_used(pt::carve_state(sim));
  std::printf("%-34s frame %3d: %4d vertices, %4d triangles, %zu tears (longest %.1f cm), %zu label tiles\n", what,
              sim.frame(), s.verts.size(), s.tris.size(), s.tears.size(), 100 * longest_tear(s),
              pt::carve_state(sim).tiles.size());
  const size_t solver = sim.solver_bytes();
  std::printf("%-34s   sheet arrays %zu B + solver %zu B + label map %lld B + fiber field %zu B = %lld B (%.1f KiB)\n", "",
              sheet, solver, static_cast<long long>(carve), sizeof(pt::FiberField),
              static_cast<long long>(sheet + solver + carve + sizeof(pt::FiberField)),
              (sheet + solver + carve + sizeof(pt::FiberField)) / 1024.0);
}

}  // namespace

int main(int argc, char** argv) {
  std::string path;
  double tear_cm = 10;
  int32_t frames = -1;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if ((a == "--tear-cm" || a == "--frames") && i + 1 < argc) {
      (a == "--tear-cm" ? tear_cm = std::atof(argv[++i]) : frames = std::atoi(argv[++i]));
    } else if (!a.empty() && a[0] != '-' && path.empty()) path = a;
    else {
      std::fprintf(stderr, "usage: papertear-memory SCENARIO [--tear-cm L] [--frames N]\n");
      return 2;
    }
  }
  if (path.empty() || tear_cm <= 0) {
    std::fprintf(stderr, "usage: papertear-memory SCENARIO [--tear-cm L] [--frames N]\n");
    return 2;
  }
  try {
    pt::Scenario sc = pt::load_scenario(path);
    if (frames > 0) sc.sim.frames = frames;
    pt::Simulation sim(sc);
    const pt::DetailParams& dp = pt::detail_params(sim);
    const double full = static_cast<double>(dp.width) * dp.height;
    std::printf("%s: texture %d x %d px at %.1f um/px, sigma %.2f mm (a full RGBA texture would be %.1f MiB, a "
                "full uint16 label map %.1f MiB)\n",
                sc.name.c_str(), dp.width, dp.height, dp.pixel_size * 1e6, dp.sigma * 1e3, full * 4 / 1048576.0,
                full * 2 / 1048576.0);
    report("no tear", sim);

    const double target = tear_cm * 1e-2;
    while (sim.frame() < sc.sim.frames && longest_tear(sim.sheet()) < target) sim.step();
    sim.flush();
    report(longest_tear(sim.sheet()) >= target ? "simulated tear" : "simulated tear (frames ran out)", sim);

    // Synthetic tear of exactly tear_cm in the same texture frame.
    std::vector<pt::Tear> tears(1);
    tears[0].id = 0;
    const pt::Vec2 top = dp.origin + 0.5 * dp.pixel_size * pt::Vec2(dp.width, dp.height) + pt::Vec2(0, 0.5 * target);
    const int32_t segments = std::max(1, static_cast<int32_t>(std::lround(target / 0.005)));
    const double step = target / segments;
    for (int32_t k = 0; k <= segments; ++k)
      tears[0].tips.push_back(top + pt::Vec2(k == 0 || k == segments ? 0.0 : (k % 2 ? 1e-3 : -1e-3), -k * step));
    pt::CarveState state;
    pt::carve_new_segments(pt::fiber_field(sim), dp, tears, state);
    std::printf("%-34s %d segments: label map %lld B (%.1f KiB, %zu tiles of %d x %d px), detail path %zu points "
                "(%zu B)\n",
                ("synthetic " + std::to_string(tear_cm).substr(0, 4) + " cm tear").c_str(), segments,
                static_cast<long long>(pt::bytes_used(state)), pt::bytes_used(state) / 1024.0, state.tiles.size(),
                pt::kTileSize, pt::kTileSize, tears[0].detail.size(), tears[0].detail.size() * sizeof(pt::Vec2));
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "papertear-memory: %s\n", e.what());
    return 1;
  }
}
