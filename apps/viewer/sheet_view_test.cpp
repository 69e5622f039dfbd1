// The viewer's frames drawn while a step runs read a SheetView and queue their edits (issue 7). Queued
// finger moves written before a step must give the very state that moving the fingers directly gives
// (the simulation keeps the last target set before a step), a move of a finger released meanwhile is
// dropped, and the view shows the queued goals.
#include "apps/viewer/sheet_view.hpp"

#include "engine/scenario.hpp"
#include "engine/simulation.hpp"

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace pt::viewer
