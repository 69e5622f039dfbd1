// One simulated sheet: built from a scenario, advanced frame by frame by a tbb::flow::graph built once
// (docs/architecture.md "The frame"), inside a task arena of `threads` workers.
#pragma once

#include "../components/sheet.hpp"
#include "scenario.hpp"

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace pt {

// Per-system wall time of one frame, milliseconds (Box2D's b2Profile). Filled where each system runs.
struct FrameProfile {
  double fingers = 0, forces = 0, integrate = 0, regions = 0, candidates = 0, clustering = 0,
         propagation = 0, remeshing = 0, relaxation = 0, carving = 0, frame = 0;
  // The paper's Table 1 groups.
  double physics() const { return forces + integrate + relaxation; }
  double geometry() const { return regions; }
  double tearing() const { return candidates + clustering + propagation + remeshing; }
};

struct TimingStat {
  double sum = 0, max = 0;
  int64_t count = 0;
  void add(double ms) {
    sum += ms;
    max = ms > max ? ms : max;
    ++count;
  }
  double avg() const { return count ? sum / static_cast<double>(count) : 0.0; }
};

// The systems of a frame: the one list of their names (result.json's "systems_ms", batch.json, the Python
// module's timings) and of the FrameProfile field each one's time is in. The static_assert below catches a
// field added without its row.
struct SystemEntry {
  const char* name;
  double FrameProfile::*ms;
};
inline constexpr std::array<SystemEntry, 11> kSystems = {{
    {"fingers", &FrameProfile::fingers},
    {"forces", &FrameProfile::forces},
    {"integrate", &FrameProfile::integrate},
    {"regions", &FrameProfile::regions},
    {"candidates", &FrameProfile::candidates},
    {"clustering", &FrameProfile::clustering},
    {"propagation", &FrameProfile::propagation},
    {"remeshing", &FrameProfile::remeshing},
    {"relaxation", &FrameProfile::relaxation},
    {"carving", &FrameProfile::carving},
    {"frame", &FrameProfile::frame},
}};
static_assert(sizeof(FrameProfile) == kSystems.size() * sizeof(double), "every FrameProfile field needs a kSystems row");

// Per system, in kSystems order.
template <typename T>
using PerSystem = std::array<T, kSystems.size()>;

struct TimingReport {
  PerSystem<TimingStat> systems;
  TimingStat physics, geometry, tearing, carving, frame;
  void add(const FrameProfile& p);
};

// Per-frame counts kept for result.json (short summaries, not dumps).
struct FrameStats {
  int32_t triangles = 0;
  int32_t regions = 0;
  int32_t junctions = 0;
  int32_t candidates = 0;
};

// The most worker threads a simulation or a batch takes (the command line's --threads range too): a
// task arena of 100 000 threads crashed on destruction.
inline constexpr int32_t kMaxThreads = 1024;

// TBB gives an arena at most its default concurrency (the CPUs this process may use) once it has made its
// workers for a first, default one, as it has by the time the engine's arena starts: asked for more, it
// printed its own "TBB Warning: The number of workers is currently limited to 1 ..." on stderr, and the
// summary claimed threads that never ran. Honouring the request instead (a global_control) made 761 threads
// for 1000 on 2 CPUs and ran 27 times slower (7.0 s against 0.26 s, 200 small parallel_for in a test
// program). So the command line and the Python module cap a thread count there and say so; results are
// the same at any count.
struct ThreadCount {
  int32_t asked = 1;
  int32_t used = 1;
};
ThreadCount usable_threads(int32_t asked);
// "" or, when capped, "<option> 1000 capped at the 2 CPUs available" (option: "--threads", "threads=").
std::string threads_cap_note(const ThreadCount& t, const std::string& option = "--threads ");

struct EngineOptions {
  int32_t threads = 2;           // task arena concurrency, 1 to kMaxThreads (else InputError)
  int32_t parallel_grain = 512;  // triangles per task; smaller sheets run their kernels serially
  bool check_invariants = false; // run check_mesh_invariants after every remesh (tests, soaks)
};

class Simulation {
 public:
  // Builds the sheet (meshing, fingers, hands) and the frame graph. Throws InputError / GeometryError.
  Simulation(const Scenario& scenario, const EngineOptions& options = {});
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  void step();              // one frame
  // Carves the segments of the last frame, which otherwise wait for the next frame's carving node (it
  // runs beside the physics). Call before reading tears' `detail` or writing results.
  void flush();
  int32_t frame() const;    // frames done
  // Why the simulation stopped before its frames ran out, "" while it runs: a vertex left ±kMaxSheetPosition
  // m (engine/scenario.hpp). step() does nothing once it is set; the result's status is "error".
  const std::string& stop_reason() const;
  double time() const;      // s

  const Sheet& sheet() const;
  const Scenario& scenario() const;
  const FrameProfile& last_profile() const;
  const TimingReport& timings() const;
  const std::vector<FrameStats>& frame_stats() const;
  const std::vector<TearEvent>& events() const;  // all events so far
  // With EngineOptions::check_invariants: one line per remesh that broke an invariant of
  // docs/architecture.md "Data and its invariants".
  const std::vector<std::string>& invariant_violations() const;
  // Largest principal in-plane strain of the sheet at the end of any frame so far (and where the physics
  // stopped for tearing).
  double max_strain() const;
  // The same over the triangles farther than 5 mm from every active tear tip at the time (the tips' own
  // strain is singular, docs/physics.md).
  double max_strain_beyond_tips() const;
  int32_t remesh_count() const;
  // Heap bytes the default implicit integrator keeps for this sheet (0 with projective dynamics or before
  // the first substep), for memory reports.
  size_t solver_bytes() const;
  int32_t threads() const;

  // Hex digest (FNV-1a 64 over the bit patterns of x, v, rest, triangles, tears) of the current state.
  std::string state_hash() const;

  void notify_topology_changed();

  // Interactive fingers (viewer, embedding). All take effect between frames and are recorded as the
  // finger's attach time, keys and release time, so a scenario written from them replays the session.
  // Puts a finger on the sheet at pattern point uv now (a vertex is inserted there); returns its index,
  // −1 when uv is outside the sheet.
  int32_t attach_finger(const std::string& name, const Vec2& uv);
  // The finger reaches `target` at the end of the next frame (a key at that time). InputError, naming the
  // finger, for an index the sheet does not have or a target that is not finite or beyond 1000 m (the
  // limit of a scenario's key positions); nothing is keyed then.
  void move_finger(int32_t finger, const Vec3& target);
  void release_finger(int32_t finger);  // InputError for an index the sheet does not have
  // Parameters a running simulation takes from its next frame on (the viewer's live panel): the
  // propagation speed k and step cap of p_next = p + k·Er·t (paper §5.2, docs/tearing.md "How far"), and the
  // detail noise σ, ω of the segments carved from now on (paper §6). Invalid values (negative k, a cap that
  // is not positive, σ < 0, ω outside [0, 1], NaN) are refused with std::invalid_argument.
  void set_propagation_speed(double speed, double max_step);
  void set_detail_noise(double sigma, double omega);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  // The internals the apps, tools and tests read (carving, fibres, candidates, solver counts, the mutable
  // sheet): free functions of engine/simulation_internals.hpp, not installed, so this header names no
  // system's type.
  friend struct SimulationInternals;
};

// FNV-1a 64 of a state, as text.
std::string hash_sheet(const Sheet& sheet);

}  // namespace pt
