// A recorded session replays to the same tears (issue 7). Drives a Simulation the way the viewer does —
// fingers attached by pattern point between frames, moved with move_finger every frame, released —
// records it with the viewer's recorder, loads the file with load_scenario and runs it for the same
// number of frames: same tears (tips, start kinds, parents) and the same state hash.
#include "apps/viewer/recorder.hpp"

#include "engine/scenario.hpp"
#include "engine/simulation.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>

namespace pt {
namespace {

std::string out_dir() {
  const std::string d = std::string(PT_BINARY_DIR) + "/viewer-replay";
  std::filesystem::create_directories(d);
  return d;
}

void expect_same_tears(const Sheet& a, const Sheet& b) {
  ASSERT_EQ(a.tears.size(), b.tears.size());
  for (size_t i = 0; i < a.tears.size(); ++i) {
    const Tear &ta = a.tears[i], &tb = b.tears[i];
    EXPECT_EQ(ta.parent, tb.parent);
    EXPECT_EQ(ta.start_kind, tb.start_kind);
    EXPECT_EQ(ta.start_frame, tb.start_frame);
    ASSERT_EQ(ta.tips.size(), tb.tips.size()) << "tear " << i;
    for (size_t k = 0; k < ta.tips.size(); ++k) {
      EXPECT_EQ(ta.tips[k].x(), tb.tips[k].x()) << "tear " << i << " tip " << k;
      EXPECT_EQ(ta.tips[k].y(), tb.tips[k].y()) << "tear " << i << " tip " << k;
    }
  }
  ASSERT_EQ(a.tips.size(), b.tips.size());
  for (size_t k = 0; k < a.tips.size(); ++k) EXPECT_EQ(a.tips[k].tear, b.tips[k].tear);
}

// The notched sheet of fig14-straight without its scripted fingers: a person puts two fingers either
// side of the notch after a few frames, pulls them apart (one up, one down, as in Fig. 14), lets go.
TEST(ViewerReplay, RecordedSessionReplaysToTheSameTears) {
  Scenario base = load_scenario(std::string(PT_SOURCE_DIR) + "/scenarios/fig14-straight.json");
  base.fingers.clear();
  base.hands.clear();
  // Not the defaults, so the recording must carry them.
  base.tearing.direction = "material_force";
  base.tearing.radius = 0.035;
  base.tearing.snap = 0.1;
  constexpr int kFrames = 75;
  Simulation live(base);
  int a = -1, b = -1;
  Vec3 a0 = Vec3::Zero(), b0 = Vec3::Zero();
  for (int f = 0; f < kFrames; ++f) {
    if (f == 3) {
      a = live.attach_finger("L", Vec2(0.054, 0.2));
      ASSERT_GE(a, 0);
      a0 = live.sheet().fingers[a].target;
    }
    if (f == 5) {
      b = live.attach_finger("R", Vec2(0.094, 0.2));
      ASSERT_GE(b, 0);
      b0 = live.sheet().fingers[b].target;
    }
    // Drag: in the view plane (x, z), a little more every frame, as mouse motion would.
    if (a >= 0 && f < 70) {
      const double s = std::min(1.0, (f - 3) / 45.0);
      live.move_finger(a, a0 + s * Vec3(-0.012, 0.0, 0.045));
    }
    if (b >= 0 && f < 70) {
      const double s = std::min(1.0, (f - 5) / 45.0);
      live.move_finger(b, b0 + s * Vec3(0.012, 0.0, -0.045));
    }
    if (f == 70) live.release_finger(a);
    live.step();
  }
  live.flush();
  ASSERT_FALSE(live.sheet().tears.empty()) << "the session should tear the sheet";

  const std::string path = out_dir() + "/session.json";
  viewer::write_session(live, path);
  const Scenario replay_scenario = load_scenario(path);
  EXPECT_EQ(replay_scenario.tearing.direction, "material_force");
  EXPECT_EQ(replay_scenario.tearing.radius, 0.035);
  EXPECT_EQ(replay_scenario.tearing.snap, std::optional<double>(0.1));
  EXPECT_EQ(replay_scenario.sim.solver, base.sim.solver);
  EXPECT_EQ(replay_scenario.material.min_step, base.material.min_step);
  EXPECT_EQ(replay_scenario.material.fiber_floor, base.material.fiber_floor);
  ASSERT_EQ(replay_scenario.sim.frames, kFrames);
  ASSERT_EQ(replay_scenario.fingers.size(), 2u);

  Simulation replay(replay_scenario);
  for (int f = 0; f < replay_scenario.sim.frames; ++f) replay.step();
  replay.flush();

  expect_same_tears(live.sheet(), replay.sheet());
  EXPECT_EQ(live.sheet().tris.size(), replay.sheet().tris.size());
  EXPECT_EQ(live.state_hash(), replay.state_hash());
  std::printf("[ replay ] %zu tears, %d triangles, hash %s\n", live.sheet().tears.size(), live.sheet().tris.size(),
              live.state_hash().c_str());
}

// The recorder keeps the scenario's own fingers and hands and its settings (here a session started with
// --set sim.relaxation=patch and other step settings), and its output loads strictly.
TEST(ViewerReplay, ScenarioFingersRoundTrip) {
  const Scenario base = load_scenario(std::string(PT_SOURCE_DIR) + "/scenarios/fig14-straight.json",
                                      {"sim.relaxation=patch", "sim.relaxation_radius=0.04",
                                       "sim.step_splits=2", "sim.split_strain_jump=0.005"});
  Simulation live(base);
  for (int f = 0; f < 20; ++f) live.step();
  const std::string path = out_dir() + "/scripted.json";
  viewer::write_session(live, path);
  const Scenario back = load_scenario(path);
  EXPECT_EQ(back.sim.relaxation, "patch");
  EXPECT_EQ(back.sim.relaxation_radius, 0.04);
  EXPECT_EQ(back.sim.step_splits, 2);
  EXPECT_EQ(back.sim.split_strain_jump, 0.005);
  ASSERT_EQ(back.fingers.size(), base.fingers.size());
  for (size_t i = 0; i < base.fingers.size(); ++i) {
    EXPECT_EQ(back.fingers[i].name, base.fingers[i].name);
    EXPECT_EQ(back.fingers[i].at, base.fingers[i].at);
    ASSERT_EQ(back.fingers[i].keys.size(), base.fingers[i].keys.size());
  }
  Simulation replay(back);
  for (int f = 0; f < 20; ++f) replay.step();
  EXPECT_EQ(live.state_hash(), replay.state_hash());
}

}  // namespace
}  // namespace pt
