// The path claims of the paper's figures over many meshes (docs/tearing.md "Measured"): for each tip
// direction (fan, material_force, tension_rays), Fig. 14's distance from the mediator and tear count,
// Fig. 14 pulled in plane, Fig. 15's distance from the hyperbola (at the files' step cap and twice it),
// Fig. 16's direction changes, and each step's angle to O'Keefe's direction, printed as distributions over
// the meshes (mesh_seed 0..N−1, rotated by 17°·seed). Compare engine changes with it, not with one mesh:
// every path is chaotic in the mesh and in the last bit of the physics. No pass or fail; 16 meshes take
// ~8 minutes on one core.
//   build/bin/papertear-path-claims [--meshes 16] [--triangles N] [--relaxation substep|next_frame|patch]
#include "engine/one_line_error.hpp"
#include "engine/scenario.hpp"
#include "engine/simulation.hpp"
#include "engine/simulation_internals.hpp"
#include "tools/path_measures.hpp"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

using namespace pt;
using namespace pt::path_claims;

namespace {

struct ClaimsOptions {
  int32_t meshes = 16;
  int32_t triangles = 0;   // every sheet meshed with this many instead of the files' ~300 (0: the files')
  std::string relaxation;  // sim.relaxation of every run instead of the files' ("": the files')
  std::string scenarios = PT_SOURCE_DIR "/scenarios";
};

struct Run {
  std::unique_ptr<Simulation> sim;
  const Sheet& sheet() const { return sim->sheet(); }
};

// One core, the mesh invariants checked after every remesh (as the scenario tests run them).
Run run_scenario(const Scenario& s) {
  EngineOptions o;
  o.threads = 1;
  o.check_invariants = true;
  Run r{std::make_unique<Simulation>(s, o)};
  for (int32_t f = 0; f < s.sim.frames; ++f) r.sim->step();
  r.sim->flush();
  return r;
}

void print_distribution(const char* what, std::vector<double> v) {
  if (v.empty()) {
    std::printf("%-42s none\n", what);
    return;
  }
  std::sort(v.begin(), v.end());
  double mean = 0;
  for (double x : v) mean += x / v.size();
  std::printf("%-42s mean %5.1f  min %5.1f  median %5.1f  max %5.1f\n", what, mean, v.front(), v[v.size() / 2],
              v.back());
}

void measure_direction(const ClaimsOptions& options, const char* direction) {
  const Scenario fig14 = load_scenario(options.scenarios + "/fig14-straight.json");
  const Scenario fig14_inplane = load_scenario(options.scenarios + "/fig14-inplane.json");
  const Scenario fig15 = load_scenario(options.scenarios + "/fig15-curved.json");
  const Scenario fig16 = load_scenario(options.scenarios + "/fig16-zigzag.json");
  std::vector<double> mediator, fig14_tears, inplane, inplane_3cm, hyperbola, hyperbola_2x, zigzag, fig16_tears;
  // Per-step errors against O'Keefe's direction (degrees), all steps of all meshes.
  std::vector<double> step_fig14, step_inplane, step_fig15, steps_fig14;
  auto append_degrees = [](const std::vector<double>& errors, std::vector<double>& all) {
    for (double e : errors) all.push_back(e * 180 / std::numbers::pi);
  };
  size_t violations = 0, refused = 0, untorn = 0;  // mesh invariants broken, substeps the solver refused
  auto tally = [&](const Run& r) {
    violations += r.sim->invariant_violations().size();
    refused += static_cast<size_t>(solver_stats(*r.sim).failures);
  };
  for (int i = 0; i < options.meshes; ++i) {
    auto remeshed = [&](Scenario s) {
      s.mesh_seed = static_cast<uint64_t>(i);
      s.mesh_rotation_deg = 17.0 * i;
      s.tearing.direction = direction;
      s.tearing.snap.reset();
      if (options.triangles > 0) s.triangles = options.triangles;
      if (!options.relaxation.empty()) s.sim.relaxation = options.relaxation;
      return s;
    };
    do {
      const Scenario s = remeshed(fig14);
      Run r = run_scenario(s);
      if (r.sheet().tears.empty()) { ++untorn; break; }
      tally(r);
      mediator.push_back(100 * mediator_error(s, r.sheet()));
      fig14_tears.push_back(static_cast<double>(r.sheet().tears.size()));
      const std::vector<double> errors = okeefe_step_errors(s, r.sheet());
      append_degrees(errors, step_fig14);
      steps_fig14.push_back(static_cast<double>(errors.size()));
    } while (false);
    do {
      const Scenario s = remeshed(fig14_inplane);
      Run r = run_scenario(s);
      if (r.sheet().tears.empty()) { ++untorn; break; }
      tally(r);
      inplane.push_back(100 * mediator_error(s, r.sheet()));
      inplane_3cm.push_back(100 * mediator_error(s, r.sheet(), 0.03));
      append_degrees(okeefe_step_errors(s, r.sheet()), step_inplane);
    } while (false);
    for (const double cap : {1.0, 2.0}) {
      Scenario s = remeshed(fig15);
      s.material.max_step *= cap;
      const Vec2 a = finger_uv(s, "A"), b = finger_uv(s, "B");
      Run r = run_scenario(s);
      if (r.sheet().tears.empty()) { ++untorn; break; }
      const std::vector<Vec2>& tips = r.sheet().tears[0].tips;
      const double d0 = (tips[0] - a).norm() - (tips[0] - b).norm();
      double worst = 0;
      for (const Vec2& p : tips) worst = std::max(worst, std::abs((p - a).norm() - (p - b).norm() - d0));
      tally(r);
      (cap == 1.0 ? hyperbola : hyperbola_2x).push_back(100 * worst / (a - b).norm());
      if (cap == 1.0) append_degrees(okeefe_step_errors(s, r.sheet()), step_fig15);
    }
    do {
      Run r = run_scenario(remeshed(fig16));
      if (r.sheet().tears.empty()) { ++untorn; break; }
      tally(r);
      zigzag.push_back(direction_changes(r.sheet().tears[0].tips, 0.2));
      fig16_tears.push_back(static_cast<double>(r.sheet().tears.size()));
    } while (false);
  }
  std::printf("tearing.direction = %s, sim.relaxation = %s\n", direction,
              options.relaxation.empty() ? "(files')" : options.relaxation.c_str());
  print_distribution("Fig. 14 mediator error, % length", mediator);
  print_distribution("Fig. 14 tears", fig14_tears);
  print_distribution("Fig. 14 in plane: mediator error, % length", inplane);
  print_distribution("  the same over the first 3 cm", inplane_3cm);
  print_distribution("Fig. 15 hyperbola error, % |AB|", hyperbola);
  print_distribution("Fig. 15 same, twice the step cap", hyperbola_2x);
  print_distribution("Fig. 16 direction changes > 0.2", zigzag);
  print_distribution("Fig. 16 tears", fig16_tears);
  print_distribution("Fig. 14 steps of tear 0", steps_fig14);
  print_distribution("Fig. 14 step error vs O'Keefe, degrees", step_fig14);
  print_distribution("Fig. 14 in plane: the same", step_inplane);
  print_distribution("Fig. 15: the same", step_fig15);
  std::printf("mesh invariant violations %zu, refused substeps %zu, runs without a tear %zu (%d runs)\n", violations,
              refused, untorn, 5 * options.meshes);
  std::fflush(stdout);
}

void print_error(const std::string& message) { print_one_line_error("papertear-path-claims", message); }

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"papertear-path-claims: the path claims of Figs. 14-16 over many meshes, for each tip direction"};
  ClaimsOptions options;
  app.add_option("--meshes", options.meshes, "meshes per scenario: mesh_seed 0..N-1, rotated 17 deg per seed (default 16)")
      ->check(CLI::Range(1, 1000));
  app.add_option("--triangles", options.triangles, "mesh every sheet with N triangles instead of the files' ~300")
      ->check(CLI::Range(2, kMaxSheetTriangles));
  app.add_option("--relaxation", options.relaxation, "sim.relaxation of every run instead of the files'")
      ->check(CLI::IsMember({"substep", "next_frame", "patch"}));
  app.add_option("--scenarios", options.scenarios, "directory of the figures' scenario files (default: the source tree's)")
      ->check(CLI::ExistingDirectory);
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {  // --help
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    print_error(e.what());
    return 2;
  }
  try {
    for (const char* direction : {"fan", "material_force", "tension_rays"}) measure_direction(options, direction);
  } catch (const InputError& e) {
    print_error(e.what());
    return 2;
  } catch (const std::exception& e) {
    print_error(std::string("internal error: ") + e.what());
    return 1;
  }
  return 0;
}
