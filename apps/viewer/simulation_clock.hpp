// The viewer's simulation clock (issue 7): which simulation frames a rendered frame steps.
#pragma once

#include <algorithm>

namespace pt::viewer {

// The simulation follows the wall clock: a frame of the scenario (1/fps seconds of simulated time) is due
// every 1/fps seconds of real time, whatever the rendering rate, so the sheet moves at its true speed
// (stepping once per rendered frame ran it 2.3x too fast at 68 frames/s). When the simulation is slower
// than real time the backlog is dropped rather than caught up (slow motion instead of a stalled view), and
// a rendered frame stops stepping once it has spent kBudget seconds on the simulation.
struct SimulationClock {
  static constexpr int kMaxStepsPerFrame = 3;
  static constexpr double kBudget = 1.0 / 60.0;
  double owed = 0;                    // simulated seconds due and not yet stepped
  double window_wall = 0, window_sim = 0, shown_speed = 0;

  // Frames to step now for `wall_dt` seconds of real time; `step` runs one and returns its cost in seconds.
  template <class Step>
  int tick(double wall_dt, double frame_dt, Step&& step) {
    owed += wall_dt;
    int steps = 0;
    double spent = 0;
    while (owed >= frame_dt && steps < kMaxStepsPerFrame && spent < kBudget) {
      spent += step();
      owed -= frame_dt;
      ++steps;
    }
    owed = std::min(owed, frame_dt);  // behind real time: drop the backlog
    window_wall += wall_dt;
    window_sim += steps * frame_dt;
    if (window_wall >= 0.5) {  // the speed over the last half second
      shown_speed = window_sim / window_wall;
      window_wall = window_sim = 0;
    }
    return steps;
  }
  double speed() const { return shown_speed; }
};

}  // namespace pt::viewer
