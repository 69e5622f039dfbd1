// The viewer's simulation clock: the sheet moves at real time whatever the rendering rate, and a slow
// simulation turns into slow motion instead of an ever-growing backlog. The background stepper runs each
// job once, in order, and wait() returns only after it finished.
#include "apps/viewer/simulation_clock.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <vector>

using pt::viewer::BackgroundStepper;
using pt::viewer::SimulationClock;

namespace {

// `seconds` of wall time rendered at `render_fps`; a rendered frame that steps lasts at least
// `step_cost` seconds per step (the step runs beside the drawing, extra steps before it). Returns the
// simulation frames stepped.
int run(SimulationClock& c, double seconds, double render_fps, double step_cost, double sim_fps = 30) {
  int steps = 0;
  double wall = 0, last_dt = 1 / render_fps;
  while (wall < seconds) {
    const int n = c.due(last_dt, 1 / sim_fps);
    EXPECT_GE(n, 0);
    EXPECT_LE(n, SimulationClock::kMaxStepsPerFrame);
    steps += n;
    last_dt = n == 0 ? 1 / render_fps : std::max(1 / render_fps, step_cost) + (n - 1) * step_cost;
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

TEST(SimulationClock, SlowRenderingStepsTwoFramesAtMost) {
  // 10 rendered frames/s owe 3 simulation frames each; two are stepped, the third dropped.
  SimulationClock c;
  EXPECT_NEAR(run(c, 10.0, 10.0, 0.0), 200, 2);
}

TEST(SimulationClock, SlowSimulationBecomesSlowMotion) {
  // Each step costs 50 ms: a rendered frame with a step lasts that long, so about 20 steps/s (the clock
  // owes 1.5 frames per such frame and drops the backlog beyond one) instead of an ever-growing debt.
  SimulationClock c;
  const int steps = run(c, 10.0, 60.0, 0.05);
  EXPECT_GT(steps, 150);
  EXPECT_LT(steps, 300);
  EXPECT_LT(c.speed(), 0.95);
}

TEST(BackgroundStepper, RunsEachJobOnceInOrderAndWaitSeesItsEffects) {
  BackgroundStepper stepper;
  std::vector<int> done;  // written by the worker, read after wait(): no lock needed
  for (int i = 0; i < 200; ++i) {
    stepper.start([&done, i] {
      if (i % 50 == 0) std::this_thread::sleep_for(std::chrono::milliseconds(2));
      done.push_back(i);
    });
    stepper.wait();
    ASSERT_EQ(done.size(), static_cast<size_t>(i + 1));
    ASSERT_EQ(done.back(), i);
    EXPECT_FALSE(stepper.busy());
  }
  stepper.wait();  // nothing in flight: returns at once
}

TEST(BackgroundStepper, DestroyedWhileIdleOrBusyJoinsCleanly) {
  std::atomic<int> runs{0};
  {
    BackgroundStepper idle;
  }
  {
    BackgroundStepper busy;
    busy.start([&runs] {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
      ++runs;
    });
    busy.wait();
  }
  EXPECT_EQ(runs.load(), 1);
}
