// The viewer's frames drawn while a step runs read a SheetView and queue their edits (issue 7). Queued
// finger moves written before a step must give the very state that moving the fingers directly gives
// (the simulation keeps the last target set before a step), a move of a finger released meanwhile is
// dropped, and the view shows the queued goals.
#include "apps/viewer/sheet_view.hpp"

#include "engine/scenario.hpp"
#include "engine/simulation.hpp"
#include "engine/simulation_internals.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

namespace pt::viewer {
namespace {

Scenario notched_sheet_without_fingers() {
  Scenario s = load_scenario(std::string(PT_SOURCE_DIR) + "/scenarios/fig14-straight.json");
  s.fingers.clear();
  s.hands.clear();
  return s;
}

// The targets a dragging user sets for finger `i` during frame f: several per frame, the last one counts.
Vec3 drag_target(const Vec3& start, int i, int f, int k) {
  const double side = i == 0 ? -1.0 : 1.0;
  return start + Vec3(side * 0.0004 * f + 1e-4 * k, 0.0, (i == 0 ? 0.0005 : -0.0005) * f);
}

TEST(SheetView, QueuedMovesGiveTheStateOfDirectMoves) {
  const Scenario base = notched_sheet_without_fingers();
  Simulation direct(base), queued(base);
  QueuedEdits edits;
  Vec3 start[2];
  constexpr int kFrames = 45, kRelease = 30;
  for (int f = 0; f < kFrames; ++f) {
    if (f == 2) {
      for (Simulation* sim : {&direct, &queued}) {
        ASSERT_EQ(sim->attach_finger("L", Vec2(0.054, 0.2)), 0);
        ASSERT_EQ(sim->attach_finger("R", Vec2(0.094, 0.2)), 1);
      }
      start[0] = direct.sheet().fingers[0].target;
      start[1] = direct.sheet().fingers[1].target;
    }
    if (f > 2) {
      for (int k = 0; k < 3; ++k)
        for (int i = 0; i < 2; ++i) {
          if (f >= kRelease && i == 0) {
            // Moved while a step ran, then let go (a sync) before the next step: the move is dropped.
            if (k == 2 && f == kRelease) {
              queue_finger_move(i, drag_target(start[i], i, f, k), edits);
              direct.release_finger(i);
              queued.release_finger(i);
            }
            continue;
          }
          direct.move_finger(i, drag_target(start[i], i, f, k));
          queue_finger_move(i, drag_target(start[i], i, f, k), edits);
        }
      ASSERT_LE(edits.moves.size(), 2u) << "one queued move per finger";
    }
    apply_queued_edits(edits, queued);
    EXPECT_TRUE(edits.moves.empty());
    direct.step();
    queued.step();
  }
  ASSERT_EQ(direct.sheet().verts.size(), queued.sheet().verts.size());
  for (int v = 0; v < direct.sheet().verts.size(); ++v)
    ASSERT_EQ(direct.sheet().verts.x[v], queued.sheet().verts.x[v]) << "vertex " << v;
  EXPECT_EQ(direct.sheet().tears.size(), queued.sheet().tears.size());
  EXPECT_EQ(direct.sheet().fingers[0].keys.size(), queued.sheet().fingers[0].keys.size());
  EXPECT_GT(direct.sheet().tears.size(), 0u) << "the pull tore the sheet (the test covers cuts)";
}

TEST(SheetView, ShowsTheSheetAndTheQueuedGoals) {
  Simulation sim(notched_sheet_without_fingers());
  ASSERT_EQ(sim.attach_finger("L", Vec2(0.054, 0.2)), 0);
  ASSERT_EQ(sim.attach_finger("R", Vec2(0.094, 0.2)), 1);
  sim.step();
  sim.release_finger(1);
  QueuedEdits edits;
  const Vec3 goal = sim.sheet().fingers[0].target + Vec3(0.01, 0, 0);
  queue_finger_move(0, goal, edits);
  SheetView view;
  capture_sheet_view(sim, edits, view);
  EXPECT_EQ(view.frame, sim.frame());
  EXPECT_EQ(view.triangles, sim.sheet().tris.size());
  EXPECT_EQ(view.vertices, sim.sheet().verts.size());
  ASSERT_EQ(view.positions.size(), static_cast<size_t>(sim.sheet().verts.size()));
  ASSERT_EQ(view.fingers.size(), 2u);
  EXPECT_TRUE(view.fingers[0].active);
  EXPECT_FALSE(view.fingers[1].active);
  EXPECT_TRUE(view.fingers[1].released);
  EXPECT_EQ(view.fingers[0].goal, goal);
  EXPECT_EQ(view.fingers[0].position, sim.sheet().verts.x[sim.sheet().fingers[0].vertex]);
  EXPECT_EQ(view.fingers[0].name, "L");
}

// A drag along a ray nearly parallel to the view plane can queue a target farther than move_finger takes
// (issue 27: it now refuses one beyond 1000 m): the move is dropped, the other moves are written.
TEST(SheetView, AMoveTheEngineRefusesIsDropped) {
  Simulation sim(notched_sheet_without_fingers());
  ASSERT_EQ(sim.attach_finger("L", Vec2(0.054, 0.2)), 0);
  ASSERT_EQ(sim.attach_finger("R", Vec2(0.094, 0.2)), 1);
  const Vec3 kept = sim.sheet().fingers[0].keys.back().position;
  const Vec3 goal = sim.sheet().fingers[1].target + Vec3(0.01, 0, 0);
  QueuedEdits edits;
  queue_finger_move(0, Vec3(0, 1e9, 0), edits);
  queue_finger_move(1, goal, edits);
  EXPECT_NO_THROW(apply_queued_edits(edits, sim));
  EXPECT_TRUE(edits.moves.empty());
  EXPECT_EQ(sim.sheet().fingers[0].keys.back().position, kept);
  EXPECT_EQ(sim.sheet().fingers[1].keys.back().position, goal);
}

TEST(SheetView, LiveMaterialIsWrittenWithTheEdits) {
  Simulation sim(notched_sheet_without_fingers());
  QueuedEdits edits;
  edits.fracture_c = 1234.0;
  edits.tip_damage = 0.4;
  apply_queued_edits(edits, sim);
  EXPECT_NE(sim.sheet().material.fracture_c, 1234.0) << "not edited: not written";
  edits.material_edited = true;
  apply_queued_edits(edits, sim);
  EXPECT_EQ(sim.sheet().material.fracture_c, 1234.0);
  EXPECT_EQ(sim.sheet().material.tip_damage, 0.4);
  EXPECT_FALSE(edits.material_edited);
}

// Setting k, the step cap, σ and ω on a running simulation before its first frame gives the very run of
// a scenario that has those values: the setters do what the scenario's values do, from the next frame.
TEST(SheetView, LiveTearingAndDetailParametersActLikeTheScenarioValues) {
  const Scenario base = load_scenario(std::string(PT_SOURCE_DIR) + "/scenarios/fig14-straight.json");
  Scenario changed = base;
  changed.material.speed = 2.5 * base.material.speed;
  changed.material.max_step = 0.6 * base.material.max_step;
  changed.detail.sigma = 3 * base.detail.sigma;
  changed.detail.omega = 0.25;
  Simulation from_file(changed), live(base);
  QueuedEdits edits = live_parameters_of(base);
  EXPECT_EQ(edits.speed, base.material.speed);
  EXPECT_EQ(edits.sigma, detail_params(live).sigma);
  edits.speed = changed.material.speed;
  edits.max_step = changed.material.max_step;
  edits.propagation_edited = true;
  edits.sigma = changed.detail.sigma;
  edits.omega = changed.detail.omega;
  edits.detail_edited = true;
  apply_queued_edits(edits, live);
  EXPECT_FALSE(edits.propagation_edited || edits.detail_edited);
  for (int f = 0; f < 60; ++f) {
    from_file.step();
    live.step();
  }
  from_file.flush();
  live.flush();
  EXPECT_GT(live.sheet().tears.size(), 0u);
  EXPECT_EQ(live.state_hash(), from_file.state_hash());
  EXPECT_EQ(carve_state(live).carved_segments, carve_state(from_file).carved_segments);
  // And they differ from the unchanged run (the test can fail).
  Simulation unchanged(base);
  for (int f = 0; f < 60; ++f) unchanged.step();
  EXPECT_NE(unchanged.state_hash(), live.state_hash());
}

TEST(SheetView, LiveParametersRefuseInvalidValues) {
  Simulation sim(notched_sheet_without_fingers());
  EXPECT_THROW(sim.set_propagation_speed(-1.0, 0.01), std::invalid_argument);
  EXPECT_THROW(sim.set_propagation_speed(1e-7, 0.0), std::invalid_argument);
  EXPECT_THROW(sim.set_propagation_speed(std::nan(""), 0.01), std::invalid_argument);
  EXPECT_THROW(sim.set_detail_noise(-1e-4, 0.5), std::invalid_argument);
  EXPECT_THROW(sim.set_detail_noise(1e-4, 1.5), std::invalid_argument);
  const double speed = sim.sheet().material.speed;
  EXPECT_EQ(sim.sheet().material.speed, speed) << "a refused value changes nothing";
}

}  // namespace
}  // namespace pt::viewer
