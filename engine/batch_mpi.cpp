#include "engine/batch_mpi.hpp"

#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <type_traits>

#ifdef PT_HAVE_MPI
#include <mpi.h>
#endif

namespace pt {

// ---- wire format ---------------------------------------------------------------------------------------

namespace {

constexpr uint32_t kRunsMagic = 0x31525350;  // "PSR1": papertear sheet runs, format 1

class Writer {
 public:
  template <class T>
  void put(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    bytes_.append(reinterpret_cast<const char*>(&value), sizeof value);
  }
  void put_string(const std::string& s) {
    put(static_cast<uint32_t>(s.size()));
    bytes_ += s;
  }
  std::string take() { return std::move(bytes_); }

 private:
  std::string bytes_;
};

class Reader {
 public:
  explicit Reader(std::string_view bytes) : bytes_(bytes) {}
  template <class T>
  T get() {
    T value;
    need(sizeof value);
    std::memcpy(&value, bytes_.data() + at_, sizeof value);
    at_ += sizeof value;
    return value;
  }
  std::string get_string() {
    const uint32_t n = get<uint32_t>();
    need(n);
    std::string s(bytes_.substr(at_, n));
    at_ += n;
    return s;
  }
  bool done() const { return at_ == bytes_.size(); }

 private:
  void need(size_t n) const {
    if (bytes_.size() - at_ < n) throw std::runtime_error("sheet runs message: truncated");
  }
  std::string_view bytes_;
  size_t at_ = 0;
};

}  // namespace

std::string encode_sheet_runs(const std::vector<SheetRun>& runs) {
  Writer w;
  w.put(kRunsMagic);
  w.put(static_cast<uint32_t>(runs.size()));
  for (const SheetRun& run : runs) {
    const SheetOutcome& o = run.outcome;
    w.put(o.index);
    w.put(o.fiber_seed);
    w.put(o.mesh_seed);
    w.put(static_cast<uint32_t>(o.varied.size()));
    for (const double v : o.varied) w.put(v);
    w.put(o.triangles);
    w.put(o.tear_length);
    w.put(o.tears);
    w.put(o.pieces);
    w.put(o.max_finger_force);
    w.put(o.frame_ms);
    w.put_string(o.hash);
    w.put_string(o.status);
    for (const TimingStat& s : run.systems) {
      w.put(s.sum);
      w.put(s.max);
      w.put(s.count);
    }
    w.put(run.frames_timed);
    w.put(static_cast<uint64_t>(run.bytes));
    w.put(static_cast<uint64_t>(run.solver_bytes));
    w.put(run.triangles);
  }
  return w.take();
}

std::vector<SheetRun> decode_sheet_runs(std::string_view bytes) {
  Reader r(bytes);
  if (r.get<uint32_t>() != kRunsMagic) throw std::runtime_error("sheet runs message: not papertear's format 1");
  const uint32_t n = r.get<uint32_t>();
  std::vector<SheetRun> runs;
  for (uint32_t k = 0; k < n; ++k) {
    SheetRun run;
    SheetOutcome& o = run.outcome;
    o.index = r.get<int32_t>();
    o.fiber_seed = r.get<uint64_t>();
    o.mesh_seed = r.get<uint64_t>();
    const uint32_t varied = r.get<uint32_t>();
    for (uint32_t v = 0; v < varied; ++v) o.varied.push_back(r.get<double>());
    o.triangles = r.get<int32_t>();
    o.tear_length = r.get<double>();
    o.tears = r.get<int32_t>();
    o.pieces = r.get<int32_t>();
    o.max_finger_force = r.get<double>();
    o.frame_ms = r.get<double>();
    o.hash = r.get_string();
    o.status = r.get_string();
    for (TimingStat& s : run.systems) {
      s.sum = r.get<double>();
      s.max = r.get<double>();
      s.count = r.get<int64_t>();
    }
    run.frames_timed = r.get<int64_t>();
    run.bytes = static_cast<size_t>(r.get<uint64_t>());
    run.solver_bytes = static_cast<size_t>(r.get<uint64_t>());
    run.triangles = r.get<double>();
    runs.push_back(std::move(run));
  }
  if (!r.done()) throw std::runtime_error("sheet runs message: bytes after the last run");
  return runs;
}

SheetRange next_sheet_range(int32_t next, int32_t sheets, int32_t ranks, int32_t threads) {
  const int64_t left = std::max<int64_t>(0, static_cast<int64_t>(sheets) - next);
  const int64_t t = std::max(1, threads);
  // Half of a fair share of what is left: big ranges while much is left (few messages), single sheets
  // (one per thread) at the end, so a rank that drew costly sheets is not waited for long.
  const int64_t share = (left + 2 * ranks - 1) / (2 * std::max(1, ranks));
  const int64_t count = std::min(left, std::clamp(share, t, 8 * t));
  return {next, static_cast<int32_t>(count)};
}

// ---- the job ------------------------------------------------------------------------------------------

namespace {

int env_int(const char* name, int fallback) {
  const char* v = std::getenv(name);
  if (!v || !*v) return fallback;
  char* end = nullptr;
  const long x = std::strtol(v, &end, 10);
  return *end == '\0' && x >= 0 && x < (1L << 30) ? static_cast<int>(x) : fallback;
}

// Open MPI's mpirun sets OMPI_COMM_WORLD_*; srun --mpi=pmix sets PMIX_RANK (and SLURM_NTASKS), a PMI-2
// launcher PMI_RANK and PMI_SIZE.
[[maybe_unused]] bool started_by_launcher() {
  return std::getenv("OMPI_COMM_WORLD_SIZE") || std::getenv("PMIX_RANK") || std::getenv("PMI_RANK");
}

}  // namespace

bool batch_mpi_built() {
#ifdef PT_HAVE_MPI
  return true;
#else
  return false;
#endif
}

BatchRanks launcher_ranks() {
  BatchRanks r;
  if (std::getenv("OMPI_COMM_WORLD_SIZE")) {
    r.rank = env_int("OMPI_COMM_WORLD_RANK", 0);
    r.size = env_int("OMPI_COMM_WORLD_SIZE", 1);
  } else if (std::getenv("PMIX_RANK")) {
    r.rank = env_int("PMIX_RANK", 0);
    r.size = env_int("SLURM_NTASKS", 1);
  } else if (std::getenv("PMI_RANK")) {
    r.rank = env_int("PMI_RANK", 0);
    r.size = env_int("PMI_SIZE", 1);
  }
  r.size = std::max(1, r.size);
  return r;
}

BatchMpi::BatchMpi() {
#ifdef PT_HAVE_MPI
  if (!started_by_launcher()) return;
  // Funneled: only this thread calls MPI; the sheets run on oneTBB's threads.
  int provided = 0;
  if (MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS)
    throw std::runtime_error("MPI_Init_thread failed");
  started_ = true;
  MPI_Comm_rank(MPI_COMM_WORLD, &ranks_.rank);
  MPI_Comm_size(MPI_COMM_WORLD, &ranks_.size);
#endif
}

BatchMpi::~BatchMpi() {
#ifdef PT_HAVE_MPI
  if (started_) MPI_Finalize();
#endif
}

RankFailure first_failure_on_ranks(const BatchRanks& ranks, int32_t key, int exit_status) {
  RankFailure f{key, ranks.rank, exit_status};
#ifdef PT_HAVE_MPI
  if (ranks.size == 1) return f;
  struct {
    int key, rank;
  } mine{key, ranks.rank}, first{};
  MPI_Allreduce(&mine, &first, 1, MPI_2INT, MPI_MINLOC, MPI_COMM_WORLD);
  f.key = first.key;
  f.rank = first.rank;
  int status = exit_status;
  MPI_Bcast(&status, 1, MPI_INT, first.rank, MPI_COMM_WORLD);
  f.exit_status = status;
#endif
  return f;
}

void abort_ranks(int exit_status) {
#ifdef PT_HAVE_MPI
  int started = 0;
  MPI_Initialized(&started);
  if (started) MPI_Abort(MPI_COMM_WORLD, exit_status);
#endif
  std::exit(exit_status);
}

#ifdef PT_HAVE_MPI
namespace {

constexpr int kTagRuns = 1;   // rank → 0: the runs of its last range (none at first), asking for the next
constexpr int kTagRange = 2;  // 0 → rank: {first, count}; count 0: no sheets left, stop
// Waiting polls at this period instead of in Open MPI's blocking calls, which spin a core at 100%: with
// as many ranks as cores that core is a sheet's. A rank asks once per range (tens of sheets' time).
constexpr auto kPoll = std::chrono::milliseconds(1);

void wait_for(MPI_Request& request) {
  for (int done = 0;;) {
    MPI_Test(&request, &done, MPI_STATUS_IGNORE);
    if (done) return;
    std::this_thread::sleep_for(kPoll);
  }
}

double thread_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

void run_range(tbb::task_arena& arena, const Scenario& base, const BatchOptions& options, SheetRange range,
               SheetRun* runs, std::atomic<int32_t>* done) {
  arena.execute([&] {
    tbb::parallel_for(0, range.count, [&](int32_t k) {
      runs[k] = run_batch_sheet(base, options, range.first + k);
      if (done) ++*done;
    });
  });
}

// A rank other than 0: ask, run, send the runs back with the next request, until told to stop.
void run_worker_rank(const Scenario& base, const BatchOptions& options) {
  tbb::task_arena arena(std::max(1, options.threads));
  std::vector<SheetRun> runs;
  for (;;) {
    const std::string payload = encode_sheet_runs(runs);
    MPI_Request sent, answered;
    int32_t range[2] = {0, 0};
    MPI_Irecv(range, 2, MPI_INT32_T, 0, kTagRange, MPI_COMM_WORLD, &answered);
    MPI_Isend(payload.data(), static_cast<int>(payload.size()), MPI_BYTE, 0, kTagRuns, MPI_COMM_WORLD, &sent);
    wait_for(sent);
    wait_for(answered);
    if (range[1] <= 0) return;
    runs.assign(static_cast<size_t>(range[1]), SheetRun{});
    run_range(arena, base, options, {range[0], range[1]}, runs.data(), nullptr);
  }
}

// Rank 0: a thread of its own runs rank 0's ranges on `threads` threads while this one hands out ranges
// and collects the other ranks' runs.
BatchOnRanks run_rank_zero(const BatchRanks& ranks, const Scenario& base, const BatchOptions& options,
                           const std::function<void(int32_t, int32_t)>& progress) {
  BatchOnRanks job;
  job.loads.resize(static_cast<size_t>(ranks.size));
  const int32_t sheets = options.sheets;
  std::vector<SheetRun> runs(static_cast<size_t>(sheets));
  std::vector<int> owner(static_cast<size_t>(sheets), -1);  // the rank each sheet was handed to
  std::vector<char> received(static_cast<size_t>(sheets), 0);
  std::mutex dispenser;
  int32_t next = 0;
  std::atomic<bool> stop{false};
  auto take = [&](int rank) {
    const std::lock_guard<std::mutex> lock(dispenser);
    if (stop) return SheetRange{next, 0};
    const SheetRange r = next_sheet_range(next, sheets, ranks.size, options.threads);
    next += r.count;
    std::fill_n(owner.begin() + r.first, r.count, rank);
    job.loads[static_cast<size_t>(rank)].ranges += r.count > 0;
    return r;
  };
  auto owned_by = [&](int32_t i, int rank) {
    const std::lock_guard<std::mutex> lock(dispenser);
    return owner[static_cast<size_t>(i)] == rank;
  };

  const auto t0 = std::chrono::steady_clock::now();
  std::atomic<int32_t> local_done{0};
  std::atomic<bool> local_finished{false};
  std::exception_ptr local_error;
  std::thread local([&] {
    try {
      tbb::task_arena arena(std::max(1, options.threads));
      for (SheetRange r = take(0); r.count > 0; r = take(0))
        run_range(arena, base, options, r, runs.data() + r.first, &local_done);
    } catch (...) {
      local_error = std::current_exception();
    }
    local_finished = true;
  });

  const double cpu0 = thread_cpu_s();
  int32_t remote_done = 0;
  try {
    for (int active = ranks.size - 1; active > 0 || !local_finished;) {
      int ready = 0;
      MPI_Status status;
      MPI_Iprobe(MPI_ANY_SOURCE, kTagRuns, MPI_COMM_WORLD, &ready, &status);
      if (!ready) {
        if (progress) progress(local_done + remote_done, sheets);
        std::this_thread::sleep_for(kPoll);
        continue;
      }
      const int from = status.MPI_SOURCE;
      int size = 0;
      MPI_Get_count(&status, MPI_BYTE, &size);
      std::string bytes(static_cast<size_t>(size), '\0');
      MPI_Recv(bytes.data(), size, MPI_BYTE, from, kTagRuns, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
      for (SheetRun& run : decode_sheet_runs(bytes)) {
        const int32_t i = run.outcome.index;
        if (i < 0 || i >= sheets || !owned_by(i, from) || received[static_cast<size_t>(i)])
          throw std::runtime_error("rank " + std::to_string(from) + " sent sheet " + std::to_string(i) +
                                   ", which it was not given");
        received[static_cast<size_t>(i)] = 1;
        runs[static_cast<size_t>(i)] = std::move(run);
        ++remote_done;
      }
      const SheetRange r = take(from);
      const int32_t reply[2] = {r.first, r.count};
      MPI_Send(reply, 2, MPI_INT32_T, from, kTagRange, MPI_COMM_WORLD);  // 8 bytes: sent eagerly
      active -= r.count == 0;
      job.messages += 2;
      job.bytes += size + static_cast<int64_t>(sizeof reply);
      if (progress) progress(local_done + remote_done, sheets);
    }
  } catch (...) {
    stop = true;
    local.join();
    throw;
  }
  local.join();
  job.coordinator_cpu_s = thread_cpu_s() - cpu0;
  if (local_error) std::rethrow_exception(local_error);
  // Every rank was told to stop only once nothing was left, after sending what it ran: a sheet missing
  // here is a bug, not an outcome to write.
  if (local_done + remote_done != sheets)
    throw std::runtime_error("batch on " + std::to_string(ranks.size) + " ranks: " +
                             std::to_string(local_done + remote_done) + " of " + std::to_string(sheets) +
                             " sheets came back");
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (progress) progress(sheets, sheets);

  for (int32_t i = 0; i < sheets; ++i) {
    RankLoad& load = job.loads[static_cast<size_t>(owner[static_cast<size_t>(i)])];
    const SheetRun& run = runs[static_cast<size_t>(i)];
    ++load.sheets;
    load.sheet_s += run.outcome.frame_ms * static_cast<double>(run.frames_timed) / 1000.0;
  }
  job.result = merge_batch_sheets(base, options, runs, wall_s);
  job.result.ranks = ranks.size;
  return job;
}

}  // namespace
#endif

BatchOnRanks run_batch_on_ranks(const BatchRanks& ranks, const Scenario& base, const BatchOptions& options,
                                const std::function<void(int32_t, int32_t)>& progress) {
  check_batch_threads(options);
  BatchOnRanks job;
#ifdef PT_HAVE_MPI
  if (ranks.size > 1) {
    if (ranks.rank == 0) return run_rank_zero(ranks, base, options, progress);
    run_worker_rank(base, options);
    return job;
  }
#endif
  job.result = run_batch(base, options, progress);
  job.loads.assign(1, RankLoad{options.sheets, 1, 0.0});
  return job;
}

}  // namespace pt
