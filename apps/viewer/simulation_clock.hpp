// The viewer's simulation clock and its background stepper (issue 7): which simulation frames a rendered
// frame steps, and a worker thread that steps one while the frame is drawn.
#pragma once

#include <algorithm>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>

namespace pt::viewer {

// The simulation follows the wall clock: a frame of the scenario (1/fps seconds of simulated time) is due
// every 1/fps seconds of real time, whatever the rendering rate, so the sheet moves at its true speed
// (stepping once per rendered frame ran it 2.3x too fast at 68 frames/s). A rendered frame steps at most
// kMaxStepsPerFrame frames; beyond that the backlog is dropped (slow motion instead of a stalled view).
struct SimulationClock {
  static constexpr int kMaxStepsPerFrame = 2;
  double owed = 0;  // simulated seconds due and not yet stepped
  double window_wall = 0, window_sim = 0, shown_speed = 0;

  // The frames to step for `wall_dt` more seconds of real time (0..kMaxStepsPerFrame), counted as stepped.
  int due(double wall_dt, double frame_dt) {
    owed += wall_dt;
    int steps = 0;
    while (owed >= frame_dt && steps < kMaxStepsPerFrame) {
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

// One job at a time on a worker thread: start() hands it over, wait() returns once it has finished. The
// viewer starts the due simulation steps after a frame has read everything it needs from the simulation;
// later frames check busy() and draw the last state while the job runs (on llvmpipe the rasterisation is
// CPU work too, on the other core), and the first frame that finds it done reads the sheet again.
class BackgroundStepper {
 public:
  BackgroundStepper() : worker_([this] { loop(); }) {}
  ~BackgroundStepper() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      quit_ = true;
    }
    wake_.notify_all();
    worker_.join();
  }
  BackgroundStepper(const BackgroundStepper&) = delete;
  BackgroundStepper& operator=(const BackgroundStepper&) = delete;

  // Runs `job` on the worker. The previous job must have finished (wait()).
  void start(std::function<void()> job) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      job_ = std::move(job);
      busy_ = true;
    }
    wake_.notify_all();
  }
  // Blocks until the job started last has finished (at once when there is none).
  void wait() {
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [this] { return !busy_; });
  }
  bool busy() {
    std::lock_guard<std::mutex> lock(mutex_);
    return busy_;
  }

 private:
  void loop() {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      wake_.wait(lock, [this] { return quit_ || job_; });
      if (quit_) return;
      std::function<void()> job = std::move(job_);
      job_ = nullptr;
      lock.unlock();
      job();
      lock.lock();
      busy_ = false;
      done_.notify_all();
    }
  }

  std::mutex mutex_;
  std::condition_variable wake_, done_;
  std::function<void()> job_;
  bool busy_ = false, quit_ = false;
  std::thread worker_;  // last: started once the rest is initialised
};

}  // namespace pt::viewer
