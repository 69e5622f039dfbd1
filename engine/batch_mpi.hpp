// A batch spread over the processes of an MPI job (`mpirun -np N papertear batch …`, docs/batch.md).
// Rank 0 hands out ranges of sheets on demand and computes sheets itself; the other ranks ask for a range,
// run it on their threads and send the sheets' runs back with their next request. Rank 0 puts the runs in
// sheet order and merges them as one process does (merge_batch_sheets), so batch.json's hashes and outcomes
// are the same at any number of ranks. Without MPI in the build, or without a launcher, a job is one rank
// and `papertear batch` is the plain run_batch.
// Not part of the installed library: the command line links it (library papertear_batch_mpi).
#pragma once

#include "engine/batch.hpp"

#include <climits>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace pt {

// This process's place in the job.
struct BatchRanks {
  int rank = 0;
  int size = 1;
};

// True when the build has MPI (Open MPI found by CMake).
bool batch_mpi_built();

// The rank and size a launcher (mpirun, srun) gave this process in its environment, before MPI starts;
// {0, 1} without one.
BatchRanks launcher_ranks();

// MPI for the lifetime of the object, started only when the build has MPI and a launcher started the
// process (so a plain `papertear batch` never touches MPI); {0, 1} otherwise. Finalized by the destructor.
class BatchMpi {
 public:
  BatchMpi();
  ~BatchMpi();
  BatchMpi(const BatchMpi&) = delete;
  BatchMpi& operator=(const BatchMpi&) = delete;
  const BatchRanks& ranks() const { return ranks_; }

 private:
  BatchRanks ranks_;
  bool started_ = false;
};

// The job's agreement on its input. Each rank passes the failure it found: `key` −1 for the scenario, the
// options or the output directory, the sheet's index for an invalid sheet, kNoFailure for none. Every rank
// gets back the lowest key of all (the lowest rank among equals), that rank and its exit status: the job
// reports what one process would have reported first.
inline constexpr int32_t kNoFailure = INT32_MAX;
struct RankFailure {
  int32_t key = kNoFailure;
  int rank = 0;
  int exit_status = 0;
};
RankFailure first_failure_on_ranks(const BatchRanks& ranks, int32_t key, int exit_status);

// Ends every process of the job with `exit_status`: a failure on one rank after the sheets started, when
// the others would wait for it.
[[noreturn]] void abort_ranks(int exit_status);

// What rank 0 saw of the distribution.
struct RankLoad {
  int32_t sheets = 0;   // sheets the rank ran
  int32_t ranges = 0;   // ranges it was handed
  double sheet_s = 0;   // the sum of its sheets' frame times, s
};
struct BatchOnRanks {
  BatchResult result;            // the whole batch on rank 0 (outcomes in sheet order); empty elsewhere
  std::vector<RankLoad> loads;   // per rank, on rank 0
  int64_t messages = 0;          // messages rank 0 received and sent
  int64_t bytes = 0;             // their payload bytes
  double coordinator_cpu_s = 0;  // CPU time of rank 0's coordinating thread (its overhead), s
};

// Runs the batch on every rank of the job (all ranks call it with the same arguments). `progress(done,
// total)` is called on rank 0's calling thread as sheets finish (may be empty).
BatchOnRanks run_batch_on_ranks(const BatchRanks& ranks, const Scenario& base, const BatchOptions& options,
                                const std::function<void(int32_t, int32_t)>& progress = {});

// The range of sheets given to a rank that asks when sheets [next, sheets) are left: guided
// self-scheduling, a share of what is left that shrinks as the batch ends (so the last sheets are spread
// one or `threads` at a time), at least `threads` sheets, at most 8 per thread.
struct SheetRange {
  int32_t first = 0, count = 0;
};
SheetRange next_sheet_range(int32_t next, int32_t sheets, int32_t ranks, int32_t threads);

// Sheet runs as bytes for a message between ranks (the same binary on every rank: native byte order).
std::string encode_sheet_runs(const std::vector<SheetRun>& runs);
// Throws std::runtime_error on a malformed message.
std::vector<SheetRun> decode_sheet_runs(std::string_view bytes);

}  // namespace pt
