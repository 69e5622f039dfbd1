// Soak (issue 9; `make soak`, scripts/soak.sh): a long run of one scenario, by default 10 000 frames of
// tests/soak/soak.json (repeated tearing while a hand waves the sheet), checking every frame for a
// non-finite value and, after every remesh, the mesh invariants (docs/architecture.md "Data and its
// invariants"). Prints per 1 000 frames the frame time, triangles, memory (current and peak RSS) and CPU
// time per triangle, so a leak or a cost that grows with the run shows. Exit status 0 when the run stayed
// finite and valid, 1 when it did not, 2 for bad options or a bad scenario.
//   build/bin/papertear-soak [--scenario FILE] [--frames N] [--threads N] [--report FILE]
#include "engine/one_line_error.hpp"
#include "engine/scenario.hpp"
#include "engine/simulation.hpp"
#include "systems/mesh/meshing.hpp"
#include "systems/common/topology.hpp"

#include <CLI/CLI.hpp>

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

using namespace pt;

namespace {

using Clock = std::chrono::steady_clock;

struct SoakOptions {
  std::string scenario = PT_SOURCE_DIR "/tests/soak/soak.json";
  int32_t frames = 0;  // 0: the scenario's sim.frames
  int32_t threads = 2;
  std::string report;  // "" : stdout only
};

long rss_kb() {
  std::ifstream f("/proc/self/statm");
  long pages = 0, resident = 0;
  f >> pages >> resident;
  return resident * 4;  // 4 KiB pages
}

// Process CPU time (all threads), ms: frame cost that does not depend on other processes sharing the cores.
double cpu_ms() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return 1e3 * (u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-3 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

long peak_rss_kb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss;
}

// Whether every position, velocity, finger and tear point is finite; `where` names the first that is not.
bool all_finite(const Sheet& s, std::string& where) {
  where = first_non_finite(s);
  return where.empty();
}

// Runs the soak; returns the exit status (0: finite and valid throughout, 1: not).
int soak(const SoakOptions& options) {
  const Scenario sc = load_scenario(options.scenario);
  const int frames = options.frames > 0 ? options.frames : sc.sim.frames;
  EngineOptions opt;
  opt.threads = options.threads;
  opt.check_invariants = true;
  std::ostringstream rep;
  const long rss0 = peak_rss_kb();
  Simulation sim(sc, opt);
  rep << "soak: " << options.scenario << ", " << frames << " frames at " << sc.sim.fps << " fps, " << opt.threads
      << " threads, peak RSS before the sheet " << rss0 << " KiB\n";
  rep << "  frames        ms/frame(avg)  ms/frame(max)  triangles(avg)  triangles(end)  vertices  pieces  tears  remeshes  "
         "RSS(KiB)  peakRSS(KiB)  cpu_ms/frame  cpu_us/frame/triangle\n";
  const auto start = Clock::now();
  double block_ms = 0, block_max = 0, block_tris = 0, block_cpu0 = cpu_ms();
  int nan_frames = 0;
  for (int f = 1; f <= frames; ++f) {
    const auto t0 = Clock::now();
    sim.step();
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    block_ms += ms;
    block_max = std::max(block_max, ms);
    block_tris += sim.sheet().tris.size();
    std::string where;
    if (!all_finite(sim.sheet(), where)) {
      ++nan_frames;
      rep << "non-finite value at frame " << f << " (" << where << ")\n";
      break;
    }
    if (f % 1000 == 0 || f == frames) {
      const int n = f % 1000 == 0 ? 1000 : f % 1000;
      const double cpu = cpu_ms() - block_cpu0;
      char line[256];
      std::snprintf(line, sizeof line, "  %5d-%-5d  %13.3f  %13.3f  %14.1f  %14d  %8d  %6d  %5zu  %8d  %8ld  %12ld  %12.3f  %21.4f\n",
                    f - n + 1, f, block_ms / n, block_max, block_tris / n, sim.sheet().tris.size(),
                    sim.sheet().verts.size(), sim.sheet().topo.piece_count, sim.sheet().tears.size(),
                    sim.remesh_count(), rss_kb(), peak_rss_kb(), cpu / n, 1000 * cpu / block_tris);
      rep << line;
      std::fputs(line, stdout);
      std::fflush(stdout);
      block_ms = block_max = block_tris = 0;
      block_cpu0 = cpu_ms();
    }
  }
  sim.flush();
  const double wall = std::chrono::duration<double>(Clock::now() - start).count();
  std::string where;
  const bool finite = all_finite(sim.sheet(), where);
  if (!finite && nan_frames == 0) rep << "non-finite value after the last frame (" << where << ")\n";
  rep << "NaN/non-finite frames: " << nan_frames << "\n";
  rep << "invariant violations: " << sim.invariant_violations().size() << "\n";
  for (size_t i = 0; i < std::min<size_t>(5, sim.invariant_violations().size()); ++i)
    rep << "  " << sim.invariant_violations()[i] << "\n";
  rep << "wall " << wall << " s, peak RSS " << peak_rss_kb() << " KiB, final hash " << sim.state_hash() << "\n";
  std::fputs(rep.str().c_str(), stdout);
  if (!options.report.empty()) {
    std::ofstream out(options.report);
    out << rep.str();
    if (!out) std::fprintf(stderr, "papertear-soak: %s: cannot write the report\n", options.report.c_str());
  }
  return finite && nan_frames == 0 && sim.invariant_violations().empty() ? 0 : 1;
}

void print_error(const std::string& message) { print_one_line_error("papertear-soak", message); }

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"papertear-soak: a long run checked every frame for NaN and after every remesh for the mesh invariants"};
  SoakOptions options;
  app.add_option("--scenario", options.scenario, "scenario file (default: tests/soak/soak.json)");
  app.add_option("--frames", options.frames, "frames to run (default: the scenario's sim.frames)")
      ->check(CLI::Range(1, 10'000'000));
  app.add_option("--threads", options.threads, "worker threads (default: 2)")->check(CLI::Range(1, kMaxThreads));
  app.add_option("--report", options.report, "also write the report to FILE");
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {  // --help
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    print_error(e.what());
    return 2;
  }
  try {
    return soak(options);
  } catch (const InputError& e) {
    print_error(e.what());
    return 2;
  } catch (const GeometryError& e) {
    print_error(options.scenario + ": " + e.what());
    return 2;
  } catch (const std::exception& e) {
    print_error(std::string("internal error: ") + e.what());
    return 1;
  }
}
