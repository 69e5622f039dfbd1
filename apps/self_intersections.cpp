// papertear-self-intersections SCENARIO [--frames N] [--every K]: runs a scenario and prints, every K
// frames, how many pairs of non-adjacent triangles intersect (systems/mesh/self_intersection.hpp), the
// measure of the sheet's self-contact (issue 25; systems/physics/self_contact.hpp handles it when the scenario
// turns sim.self_contact on).
#include "engine/scenario.hpp"
#include "engine/simulation.hpp"
#include "systems/mesh/self_intersection.hpp"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: papertear-self-intersections SCENARIO [--frames N] [--every K]\n");
    return 2;
  }
  int frames = -1, every = 10;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string option = argv[i];
    const int value = std::atoi(argv[i + 1]);
    if (value < 1) {
      std::fprintf(stderr, "papertear-self-intersections: %s: expected a positive integer\n", option.c_str());
      return 2;
    }
    if (option == "--frames") frames = value;
    else if (option == "--every") every = value;
    else {
      std::fprintf(stderr, "papertear-self-intersections: unknown option %s\n", option.c_str());
      return 2;
    }
  }
  try {
    const pt::Scenario scenario = pt::load_scenario(argv[1]);
    pt::Simulation sim(scenario);
    if (frames < 0) frames = scenario.sim.frames;
    int64_t worst = 0, frames_with = 0, checks = 0;
    std::printf("frame triangles intersecting candidates ms\n");
    for (int f = 1; f <= frames; ++f) {
      sim.step();
      if (f % every != 0 && f != frames) continue;
      const auto t0 = std::chrono::steady_clock::now();
      const pt::SelfIntersectionCount c = pt::count_self_intersections(sim.sheet().verts.x, sim.sheet().tris.tri);
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      std::printf("%d %d %lld %lld %.2f\n", f, sim.sheet().tris.size(), static_cast<long long>(c.intersecting),
                  static_cast<long long>(c.candidates), ms);
      worst = std::max(worst, c.intersecting);
      frames_with += c.intersecting > 0;
      checks += 1;
    }
    std::printf("%s: largest %lld intersecting pairs; %lld of %lld checked frames have some\n", argv[1],
                static_cast<long long>(worst), static_cast<long long>(frames_with), static_cast<long long>(checks));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  }
  return 0;
}
