// papertear-self-intersections SCENARIO [--frames N] [--every K] [--substeps] [--set KEY=VALUE]...: runs a
// scenario and prints, every K frames, how many pairs of non-adjacent triangles intersect
// (systems/mesh/self_intersection.hpp), the measure of the sheet's self-contact (issue 25;
// systems/physics/self_contact.hpp handles it when the scenario turns sim.self_contact on). With
// --substeps it checks the state after every substep instead (the physics' and the relaxations' after
// cuts) and prints each substep that has a pair, with the frame it belongs to.
#include "engine/scenario.hpp"
#include "engine/simulation.hpp"
#include "engine/simulation_internals.hpp"
#include "systems/mesh/self_intersection.hpp"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace {
int usage() {
  std::fprintf(stderr,
               "usage: papertear-self-intersections SCENARIO [--frames N] [--every K] [--substeps] [--set KEY=VALUE]...\n");
  return 2;
}
}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage();
  int frames = -1, every = 10;
  bool substeps = false;
  std::vector<std::string> settings;
  for (int i = 2; i < argc; ++i) {
    const std::string option = argv[i];
    if (option == "--substeps") {
      substeps = true;
      continue;
    }
    if (i + 1 >= argc) return usage();
    const std::string value = argv[++i];
    if (option == "--set") {
      settings.push_back(value);
      continue;
    }
    const int n = std::atoi(value.c_str());
    if (n < 1) {
      std::fprintf(stderr, "papertear-self-intersections: %s: expected a positive integer\n", option.c_str());
      return 2;
    }
    if (option == "--frames") frames = n;
    else if (option == "--every") every = n;
    else {
      std::fprintf(stderr, "papertear-self-intersections: unknown option %s\n", option.c_str());
      return 2;
    }
  }
  try {
    const pt::Scenario scenario = pt::load_scenario(argv[1], settings);
    pt::Simulation sim(scenario);
    if (frames < 0) frames = scenario.sim.frames;
    int64_t worst = 0, with = 0, checks = 0;
    int frame = 1, substep = 0;
    auto record = [&](const pt::SelfIntersectionCount& c) {
      worst = std::max(worst, c.intersecting);
      with += c.intersecting > 0;
      checks += 1;
    };
    if (substeps) {
      std::printf("frame substep triangles intersecting candidates\n");
      pt::set_substep_observer(sim, [&](const pt::Sheet& s) {
        substep += 1;
        const pt::SelfIntersectionCount c = pt::count_self_intersections(s.verts.x, s.tris.tri);
        if (c.intersecting > 0)
          std::printf("%d %d %d %lld %lld\n", frame, substep, s.tris.size(), static_cast<long long>(c.intersecting),
                      static_cast<long long>(c.candidates));
        record(c);
      });
    } else {
      std::printf("frame triangles intersecting candidates ms\n");
    }
    for (; frame <= frames; ++frame) {
      substep = 0;
      sim.step();
      if (substeps || (frame % every != 0 && frame != frames)) continue;
      const auto t0 = std::chrono::steady_clock::now();
      const pt::SelfIntersectionCount c = pt::count_self_intersections(sim.sheet().verts.x, sim.sheet().tris.tri);
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      std::printf("%d %d %lld %lld %.2f\n", frame, sim.sheet().tris.size(), static_cast<long long>(c.intersecting),
                  static_cast<long long>(c.candidates), ms);
      record(c);
    }
    std::printf("%s: largest %lld intersecting pairs; %lld of %lld checked %s have some\n", argv[1],
                static_cast<long long>(worst), static_cast<long long>(with), static_cast<long long>(checks),
                substeps ? "substeps" : "frames");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  }
  return 0;
}
