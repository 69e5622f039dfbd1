// Batches of sheets (docs/architecture.md "The frame"; docs/result-format.md, `papertear batch`): N
// variations of one scenario advanced in parallel, each sheet with its own frame graph; oneTBB's work
// stealing balances sheets of different cost. Results and hashes do not depend on the thread count: each
// sheet is deterministic on its own.
#pragma once

#include "scenario.hpp"
#include "simulation.hpp"

#include <array>
#include <functional>
#include <string>
#include <vector>

namespace pt {

// --vary KEY=FROM:TO: sheet i of N gets FROM + (TO − FROM) · i / (N − 1).
struct Variation {
  std::string key;  // material.<name>, sim.substeps, sim.iterations, detail.sigma, detail.omega, finger_speed
  double from = 0, to = 0;
};
// Parses "KEY=FROM:TO"; throws InputError naming the argument on a bad key or number.
Variation parse_variation(const std::string& text);

// The keys --vary accepts, in the order `batch --help` lists them.
const std::vector<std::string>& variation_keys();

struct BatchOptions {
  int32_t sheets = 8;
  int32_t threads = 2;
  int32_t frames = -1;               // −1: the scenario's
  std::vector<Variation> vary;
  int32_t threads_per_sheet = 1;     // each sheet's own arena (nested parallelism for big sheets)
  // Every sheet keeps the scenario's fibre and mesh seeds, so a sweep varies only what --vary names
  // (otherwise sheet i > 0 gets seeds derived from i).
  bool fixed_seeds = false;
};

struct SheetOutcome {
  int32_t index = 0;
  uint64_t fiber_seed = 0, mesh_seed = 0;
  std::vector<double> varied;        // values of BatchOptions::vary for this sheet
  int32_t triangles = 0;
  double tear_length = 0;            // sum of coarse path lengths, m
  int32_t tears = 0;
  int32_t pieces = 1;
  double max_finger_force = 0;       // N
  double frame_ms = 0;               // average per frame
  std::string hash;
  std::string status = "ok";
};

struct SystemThroughput {
  int64_t calls = 0;                 // frames in which the system ran
  double total_ms = 0;
  double triangles = 0;              // triangles processed (triangle count × calls)
};

struct BatchResult {
  int32_t sheets = 0, threads = 0, frames = 0;
  int32_t ranks = 1;                            // MPI ranks that ran the sheets (threads is per rank);
                                                // batch.json has "ranks" only when it is more than 1
  std::vector<Variation> vary;                  // what was varied (SheetOutcome::varied in this order)
  bool fixed_seeds = false;
  double wall_s = 0, sheet_frames_per_s = 0;
  PerSystem<TimingStat> systems;                // per frame over all sheets
  PerSystem<SystemThroughput> throughput;
  std::vector<SheetOutcome> outcomes;           // in sheet order
  size_t bytes_per_sheet = 0;                   // average sheet data size (excluding texture), B
  size_t solver_bytes_per_sheet = 0;            // average memory of the sheet's implicit solver (matrix, factor), B
};

// The scenario of sheet `index` (seeds derived from the index, variations applied).
Scenario batch_sheet_scenario(const Scenario& base, const BatchOptions& options, int32_t index);

// Throws the InputError of sheet `index`'s scenario if it is invalid, the message naming the sheet, so that
// a bad --vary range fails before any sheet runs.
void validate_batch_sheet(const Scenario& base, const BatchOptions& options, int32_t index);

// Throws InputError unless threads and threads_per_sheet are 1 to kMaxThreads.
void check_batch_threads(const BatchOptions& options);

// A batch runs up to `at_once` sheets at once (its threads, capped at the CPUs): their estimated memory (the
// mesh may have 20% more triangles than asked) must fit what the process may use, the machine's memory or
// a lower address-space limit (ulimit -v), which a sheet alone at the scenario cap does. Throws InputError
// naming `option` ("--threads" on the command line, "threads" in Python) when it does not.
void check_batch_memory(int32_t at_once, int32_t triangles, const std::string& option = "--threads");

// Runs the batch. `progress(done, total)` is called from worker threads after each sheet (may be empty).
BatchResult run_batch(const Scenario& base, const BatchOptions& options,
                      const std::function<void(int32_t, int32_t)>& progress = {});

// What one sheet of a batch leaves for the batch's result: its outcome and what the merge sums. A sheet that
// throws is an outcome with status "error: …", not an exception. run_batch is run_batch_sheet for every
// sheet and merge_batch_sheets over them; engine/batch_mpi.cpp runs the sheets on several processes.
struct SheetRun {
  SheetOutcome outcome;
  PerSystem<TimingStat> systems;       // over the sheet's frames
  int64_t frames_timed = 0;            // TimingReport::frame.count
  size_t bytes = 0, solver_bytes = 0;  // sheet_bytes and the solver's at the end
  double triangles = 0;                // triangles processed, summed over the frames
};
SheetRun run_batch_sheet(const Scenario& base, const BatchOptions& options, int32_t index);

// The batch's result from every sheet's run, `runs[i]` being sheet i's; sums in sheet order, so they do
// not depend on which thread or process ran a sheet. `wall_s`: the batch's time.
BatchResult merge_batch_sheets(const Scenario& base, const BatchOptions& options, const std::vector<SheetRun>& runs,
                               double wall_s);

void write_batch_json(const BatchResult& result, const std::string& scenario_name, const std::string& path);
void write_batch_csv(const BatchResult& result, const std::string& path);

// Heap bytes held by a sheet's arrays (capacity-based), for memory reports.
size_t sheet_bytes(const Sheet& sheet);

}  // namespace pt
