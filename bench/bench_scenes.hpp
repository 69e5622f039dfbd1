// Scenes shared by the benchmarks: an A4 sheet of about N triangles held by two hands that pull apart
// and twist (scenarios/demo.json, docs/scenario-format.md), built in code so each benchmark picks its size.
#pragma once

#include "engine/scenario.hpp"
#include "systems/mesh/meshing.hpp"

namespace pt::bench {

inline Scenario a4_scene(int32_t triangles, bool notch = true) {
  Scenario s;
  s.name = "bench-a4";
  if (notch) {
    s.outline = {Vec2(0, 0), Vec2(0.21, 0), Vec2(0.21, 0.297), Vec2(0.109, 0.297), Vec2(0.105, 0.28),
                 Vec2(0.101, 0.297), Vec2(0, 0.297)};
  } else {
    s.outline = preset_outline("A4");
  }
  s.triangles = triangles;
  s.sim.frames = 60;
  auto finger = [](const char* name, double u, double v, Vec3 to) {
    FingerSpec f;
    f.name = name;
    f.at = Vec2(u, v);
    f.keys = {FingerKey{0.0, Vec3(u, v, 0)}, FingerKey{2.0, Vec3(u, v, 0) + to}};
    return f;
  };
  s.fingers = {finger("A", 0.085, 0.29, Vec3(-0.004, 0.0, 0.03)), finger("B", 0.125, 0.29, Vec3(0.004, 0.0, -0.03))};
  return s;
}

}  // namespace pt::bench
