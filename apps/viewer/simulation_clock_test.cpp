// The viewer's simulation clock: the sheet moves at real time whatever the rendering rate, and a slow
// simulation turns into slow motion instead of an ever-growing backlog.
#include "apps/viewer/simulation_clock.hpp"

#include <gtest/gtest.h>

using pt::viewer::SimulationClock;

namespace {

// `seconds` of wall time rendered at `render_fps`, each simulation frame costing `step_cost` seconds (added
// to that rendered frame's wall time, as in the viewer's loop). Returns the simulation frames stepped.
int run(SimulationClock& c, double seconds, double render_fps, double step_cost, double sim_fps = 30) {
  int steps = 0;
  double wall = 0, last_dt = 1 / render_fps;
  while (wall < seconds) {
    int now = 0;
    const int n = c.tick(last_dt, 1 / sim_fps, [&] {
      ++now;
      return step_cost;
    });
    EXPECT_EQ(n, now);
    steps += n;
    last_dt = 1 / render_fps + n * step_cost;
    wall += last_dt;
    EXPECT_LE(c.owed, 1 / sim_fps + 1e-12) << "no backlog beyond one frame";
  }
  return steps;
}

}  // namespace

TEST(SimulationClock, FollowsRealTimeAtAnyRenderingRate) {
  for (const double fps : {24.0, 60.0, 144.0, 500.0}) {
    SimulationClock c;
    const int steps = run(c, 10.0, fps, 0.0);
    EXPECT_NEAR(steps, 300, 2) << fps << " rendered frames/s";
    EXPECT_NEAR(c.speed(), 1.0, 0.1) << fps;
  }
}

TEST(SimulationClock, CatchesUpWithinItsBudgetWhenRenderingIsSlow) {
  // 10 rendered frames/s, 1 ms steps: each rendered frame lasts 103 ms and owes 3.09 frames; three (the
  // most one rendered frame steps) are stepped, the rest is dropped: 97% of real time.
  SimulationClock c;
  EXPECT_NEAR(run(c, 10.0, 10.0, 0.001), 291, 4);
}

TEST(SimulationClock, SlowSimulationBecomesSlowMotion) {
  // Each step costs 50 ms: more than the budget, so one per rendered frame, and the sheet runs slower than
  // real time instead of owing ever more frames.
  SimulationClock c;
  const int steps = run(c, 10.0, 60.0, 0.05);
  EXPECT_LT(steps, 200);
  EXPECT_GT(steps, 100);
  EXPECT_LT(c.speed(), 0.7);
}

TEST(SimulationClock, PausedTimeIsNotOwed) {
  // The viewer does not call tick while paused; the first tick after a long pause owes at most a frame.
  SimulationClock c;
  run(c, 1.0, 60.0, 0.0);
  int steps = c.tick(0.1, 1.0 / 30, [] { return 0.0; });  // the viewer caps a frame's dt at 0.1 s
  EXPECT_LE(steps, SimulationClock::kMaxStepsPerFrame);
  EXPECT_LE(c.owed, 1.0 / 30 + 1e-12);
}
