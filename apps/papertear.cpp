// papertear: the command line (docs/result-format.md, docs/scenario-format.md).
//   papertear run SCENARIO [--set KEY=VALUE]... [--out DIR] [--frames N] [--threads N] [--obj] [--svg] [--png]
//   papertear check SCENARIO [--set KEY=VALUE]...
//   papertear batch SCENARIO --sheets N [--set KEY=VALUE]... [--threads N] [--frames N] [--out DIR]
//                   [--vary KEY=FROM:TO]... [--fixed-seeds]
//   mpirun -np N papertear batch …   (the sheets spread over N processes, docs/batch.md)
// Exit status: 0 success; 2 invalid input (one line on stderr naming the file and the JSON path or the
// geometric problem; nothing written); 1 internal failure or output that could not be written (one line
// on stderr; never a crash). SIGINT or SIGTERM during run removes its partial output, then ends the process
// by that signal.
#include "engine/batch.hpp"
#include "engine/one_line_error.hpp"
#include "engine/batch_mpi.hpp"
#include "engine/version.hpp"
#include "engine/result_writer.hpp"
#include "engine/scenario.hpp"
#include "engine/simulation.hpp"
#include "engine/simulation_internals.hpp"
#include "engine/texture_export.hpp"
#include "systems/solver/dense_kernels.hpp"
#include "systems/mesh/meshing.hpp"

#include <CLI/CLI.hpp>
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <regex>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <memory>
#include <optional>
#include <iostream>
#include <mutex>
#include <string>
#include <system_error>
#include <vector>

namespace fs = std::filesystem;

namespace {

constexpr int kExitOk = 0;
constexpr int kExitInternal = 1;
constexpr int kExitInput = 2;

// An invalid command line or output location: exit status 2 like bad scenario input.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Under mpirun every process parses the same command line: the ranks other than 0 keep quiet, so a bad
// option is one line, not one per rank (a rank that finds a bad sheet reports it with report_error).
bool g_quiet = false;

// A run's output could not be written (a full disk): exit status 1 with one line, not an internal error.
struct OutputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// SIGINT or SIGTERM during `run`: the frame loop stops after the current frame and unwinds, so OutputDir
// removes the partial frames and a directory this run created; main then ends by the same signal. A
// second signal ends the process at once (the handler restores the default).
volatile std::sig_atomic_t g_stop_signal = 0;

extern "C" void on_stop_signal(int sig) {
  g_stop_signal = sig;
  std::signal(sig, SIG_DFL);
}

struct Interrupted : std::runtime_error {
  explicit Interrupted(const std::string& what, int sig) : std::runtime_error(what), signal(sig) {}
  int signal;
};

void throw_if_interrupted(int32_t frame) {
  const int sig = g_stop_signal;
  if (sig == 0) return;
  throw Interrupted(std::string(sig == SIGINT ? "SIGINT" : "SIGTERM") + " at frame " + std::to_string(frame) +
                        ": the run stopped, its partial output removed",
                    sig);
}

void report_error(const std::string& message) { pt::print_one_line_error("papertear", message); }

void print_error(const std::string& message) {
  if (!g_quiet) report_error(message);
}

struct RunOptions {
  std::string scenario;
  std::vector<std::string> settings;  // --set KEY=VALUE
  std::string out;
  bool out_given = false;  // --out was on the command line (so "" is refused, not the default)
  int32_t frames = -1;  // −1: the scenario's
  int32_t threads = 2;
  bool obj = false, svg = false, png = false;
};

struct BatchCli {
  std::string scenario;
  std::vector<std::string> settings;
  std::string out;
  bool out_given = false;
  int32_t sheets = 0;
  int32_t threads = 2;
  int32_t frames = -1;
  std::vector<std::string> vary;
  bool fixed_seeds = false;
};

// A progress bar on a terminal only: logs and pipes stay quiet.
class Progress {
 public:
  explicit Progress(int64_t total) : Progress(total, ::isatty(STDERR_FILENO) == 1 ? stderr : nullptr) {}
  // On `stream`, none if null.
  Progress(int64_t total, std::FILE* stream) : total_(total), stream_(stream), enabled_(stream != nullptr) {}
  ~Progress() { finish(); }

  void update(int64_t done) {
    if (!enabled_) return;
    const auto now = std::chrono::steady_clock::now();
    if (done < total_ && now - last_ < std::chrono::milliseconds(100)) return;
    last_ = now;
    constexpr int kWidth = 30;
    const int filled = total_ > 0 ? static_cast<int>(kWidth * done / total_) : kWidth;
    std::string bar(static_cast<size_t>(filled), '#');
    bar.append(static_cast<size_t>(kWidth - filled), '.');
    std::fprintf(stream_, "\r[%s] %lld/%lld", bar.c_str(), static_cast<long long>(done),
                 static_cast<long long>(total_));
    std::fflush(stream_);
    drawn_ = true;
  }

  void finish() {
    if (!drawn_) return;
    std::fprintf(stream_, "\r%*s\r", 60, "");
    std::fflush(stream_);
    drawn_ = false;
  }

 private:
  int64_t total_;
  std::FILE* stream_;
  bool enabled_;
  bool drawn_ = false;
  std::chrono::steady_clock::time_point last_{};
};

// The output directory of a run: refused before any work if it is a file; created once the input is
// valid and before any sheet runs (a location that cannot be a writable directory is a bad --out, exit 2);
// removed again (with partial frames) when the run fails, if this run created it.
class OutputDir {
 public:
  explicit OutputDir(fs::path dir) : dir_(std::move(dir)) {
    std::error_code ec;
    if (fs::exists(dir_, ec) && !fs::is_directory(dir_, ec))
      throw UsageError("--out " + dir_.string() + ": exists and is not a directory");
  }

  void create() {
    std::error_code ec;
    created_ = !fs::exists(dir_, ec);
    fs::create_directories(dir_, ec);
    if (ec) {
      created_ = false;
      throw UsageError("--out " + dir_.string() + ": cannot create the directory: " + ec.message());
    }
    if (::access(dir_.c_str(), W_OK | X_OK) != 0)
      throw UsageError("--out " + dir_.string() + ": cannot write into the directory: " + std::strerror(errno));
  }

  const fs::path& path() const { return dir_; }

  void commit() { committed_ = true; }

  ~OutputDir() {
    if (committed_) return;
    std::error_code ec;
    if (!partial_frames_.empty()) fs::remove_all(partial_frames_, ec);
    if (created_ && fs::is_empty(dir_, ec)) fs::remove(dir_, ec);
  }

  // OBJ frames go to a hidden directory renamed to frames/ at the end, so an interrupted run does not
  // leave a half sequence that looks complete.
  fs::path begin_frames() {
    partial_frames_ = dir_ / (".frames.partial." + std::to_string(static_cast<long>(::getpid())));
    std::error_code ec;
    remove_stale_partial_frames();
    fs::remove_all(partial_frames_, ec);
    fs::create_directories(partial_frames_, ec);
    if (ec) throw std::runtime_error("cannot create " + partial_frames_.string() + ": " + ec.message());
    return partial_frames_;
  }

  // The new frames replace an earlier run's in DIR/frames/: only the files --obj writes go, a user's own
  // files there stay.
  void end_frames() {
    const fs::path frames = dir_ / "frames";
    std::error_code ec;
    if (!fs::exists(frames, ec)) {
      fs::rename(partial_frames_, frames, ec);
      if (ec) throw std::runtime_error("cannot rename " + partial_frames_.string() + ": " + ec.message());
      partial_frames_.clear();
      return;
    }
    if (!fs::is_directory(frames, ec)) throw std::runtime_error(frames.string() + " exists and is not a directory");
    std::vector<fs::path> old;
    for (const fs::directory_entry& e : fs::directory_iterator(frames, ec))
      if (e.is_regular_file() && is_frame_output(e.path().filename().string())) old.push_back(e.path());
    for (const fs::path& f : old) fs::remove(f, ec);
    for (const fs::directory_entry& e : fs::directory_iterator(partial_frames_, ec)) {
      fs::rename(e.path(), frames / e.path().filename(), ec);
      if (ec) throw std::runtime_error("cannot move " + e.path().string() + " into " + frames.string() + ": " + ec.message());
    }
    fs::remove(partial_frames_, ec);
    partial_frames_.clear();
  }

  // A run killed outright (SIGKILL, a crash) could not remove its hidden frames: the next --obj run into
  // the same directory removes those of processes that no longer exist.
  void remove_stale_partial_frames() {
    static const std::regex pattern(R"(\.frames\.partial\.([0-9]{1,9}))");
    std::error_code ec;
    std::vector<fs::path> stale;
    for (const fs::directory_entry& e : fs::directory_iterator(dir_, ec)) {
      std::smatch m;
      const std::string name = e.path().filename().string();
      if (!std::regex_match(name, m, pattern)) continue;
      const long pid = std::stol(m[1].str());
      if (pid != static_cast<long>(::getpid()) && ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH)
        stale.push_back(e.path());
    }
    for (const fs::path& p : stale) fs::remove_all(p, ec);
  }

  // What --obj writes into frames/: frame_NNNN.obj and .mtl, carved_NNNN.png, paper.png.
  static bool is_frame_output(const std::string& name) {
    static const std::regex pattern(R"((frame_[0-9]{4,}\.(obj|mtl))|(carved_[0-9]{4,}\.png)|(paper\.png))");
    return std::regex_match(name, pattern);
  }

 private:
  fs::path dir_;
  fs::path partial_frames_;
  bool created_ = false;
  bool committed_ = false;
};

std::string plural(int64_t n, const char* word) {
  return std::to_string(n) + " " + word + (n == 1 ? "" : "s");
}

std::string gigabytes(double bytes) {
  char buf[32];
  if (bytes >= 1e12) std::snprintf(buf, sizeof buf, "%.1f TB", bytes / 1e12);
  else std::snprintf(buf, sizeof buf, "%.3g GB", bytes / 1e9);
  return buf;
}

// --obj writes every frame: refused before the run when the estimate does not fit the free space of the
// disk that will hold `dir` (19 GB in 10 minutes of a small sheet's frames filled disks unasked).
void check_space_for_obj(const fs::path& dir, double estimate, int32_t frames, int32_t triangles) {
  std::error_code ec;
  fs::path existing = fs::absolute(dir, ec);
  while (!ec && !fs::exists(existing, ec) && existing.has_relative_path()) existing = existing.parent_path();
  const fs::space_info space = fs::space(existing, ec);
  if (ec || static_cast<double>(space.available) >= estimate) return;
  throw UsageError("--obj: " + plural(frames, "textured frame") + " of " + plural(triangles, "triangle") +
                   " need about " + gigabytes(estimate) + " on disk, but " + existing.string() + " has " +
                   gigabytes(static_cast<double>(space.available)) + " free (fewer --frames, or no --obj)");
}

// --out "" given on the command line: refused rather than read as "the default".
void check_out_given(bool given, const std::string& out) {
  if (given && out.empty()) throw UsageError("--out: empty directory name (omit --out for the default)");
}

int run_command(const RunOptions& opt) {
  check_out_given(opt.out_given, opt.out);
  pt::Scenario scenario = pt::load_scenario(opt.scenario, opt.settings);
  if (opt.frames >= 0) scenario.sim.frames = opt.frames;
  OutputDir out(opt.out.empty() ? fs::path("out") / scenario.name : fs::path(opt.out));

  const pt::ThreadCount threads = pt::usable_threads(opt.threads);
  pt::EngineOptions engine;
  engine.threads = threads.used;
  g_stop_signal = 0;
  std::signal(SIGINT, on_stop_signal);
  std::signal(SIGTERM, on_stop_signal);
  pt::Simulation sim(scenario, engine);  // meshing problems surface here, before anything is written
  if (opt.obj)
    check_space_for_obj(out.path(), pt::estimated_obj_bytes(sim, scenario.sim.frames), scenario.sim.frames,
                        sim.sheet().tris.size());
  throw_if_interrupted(0);

  out.create();
  // A result left by an earlier run must not pass for this run's if this one fails.
  std::error_code ec;
  const fs::path result_path = out.path() / "result.json";
  fs::remove(result_path, ec);

  fs::path frames_dir;
  std::unique_ptr<pt::TexturedObjWriter> obj_writer;
  if (opt.obj) {
    frames_dir = out.begin_frames();
    obj_writer = std::make_unique<pt::TexturedObjWriter>(frames_dir.string());
  }
  {
    Progress progress(scenario.sim.frames);
    for (int32_t f = 0; f < scenario.sim.frames; ++f) {
      sim.step();
      if (!sim.stop_reason().empty()) break;  // far from the origin: result.json says why
      if (opt.obj) {
        // Textured frames (OBJ + MTL, paper.png once, the carved atlas when carving changed): carve this
        // frame's segments now (the carving node would do it beside the next frame's physics; the result
        // is the same) so each frame shows its own tear.
        sim.flush();
        char stem[32];
        std::snprintf(stem, sizeof stem, "frame_%04d", sim.frame());
        try {
          obj_writer->write(sim, stem);
        } catch (const std::exception& e) {
          throw OutputError("--obj: frame " + std::to_string(sim.frame()) + ": " + e.what() +
                            "; the run stopped, its partial frames removed");
        }
      }
      progress.update(f + 1);
      throw_if_interrupted(sim.frame());
    }
  }
  sim.flush();

  std::vector<std::string> written;
  if (opt.svg) {
    const fs::path svg = out.path() / "pattern.svg";
    pt::write_svg(sim, svg.string());
    written.push_back(svg.string());
  }
  if (opt.png) {
    const fs::path png = out.path() / "pattern.png";
    pt::write_pattern_png(png.string(), scenario.outline, sim.sheet().tears, pt::carve_state(sim), pt::detail_params(sim),
                          pt::fiber_field(sim));
    written.push_back(png.string());
  }
  if (opt.obj) {
    out.end_frames();
    written.push_back((out.path() / "frames").string() + "/ (" + plural(sim.frame(), "textured OBJ frame") + ", " +
                      plural(obj_writer->carved_textures_written(), "carved texture") + ")");
  }
  // result.json last: its presence means the run completed.
  std::string error;
  const bool ok = pt::write_result_json(sim, result_path.string(), &error);
  written.insert(written.begin(), result_path.string());
  out.commit();

  const pt::Sheet& sheet = sim.sheet();
  const std::string cap = pt::threads_cap_note({threads.asked, sim.threads()});
  std::printf("%s: %s, %s, %s, %s, %.3f ms/frame (%s%s%s)\n", scenario.name.c_str(), plural(sim.frame(), "frame").c_str(),
              plural(sheet.tris.size(), "triangle").c_str(), plural(static_cast<int64_t>(sheet.tears.size()), "tear").c_str(),
              plural(sheet.topo.piece_count, "piece").c_str(), sim.timings().frame.avg(),
              plural(sim.threads(), "thread").c_str(), cap.empty() ? "" : "; ", cap.c_str());
  for (const std::string& w : written) std::printf("wrote %s\n", w.c_str());
  std::fflush(stdout);
  if (!ok) {
    print_error(result_path.string() + ": status \"error\": " + error);
    return kExitInternal;
  }
  return kExitOk;
}

int check_command(const std::string& path, const std::vector<std::string>& settings) {
  const pt::Scenario s = pt::load_scenario(path, settings);
  std::printf("%s: ok: \"%s\", %s, %s, %d triangles, %d frames at %g fps\n", path.c_str(), s.name.c_str(),
              plural(static_cast<int64_t>(s.fingers.size()), "finger").c_str(),
              plural(static_cast<int64_t>(s.hands.size()), "hand").c_str(), s.triangles, s.sim.frames, s.sim.fps);
  return kExitOk;
}

pt::BatchOptions batch_options(const BatchCli& cli) {
  pt::BatchOptions options;
  options.sheets = cli.sheets;
  const pt::ThreadCount threads = pt::usable_threads(cli.threads);
  options.threads = threads.used;
  options.frames = cli.frames;
  options.fixed_seeds = cli.fixed_seeds;
  for (const std::string& v : cli.vary) options.vary.push_back(pt::parse_variation(v));
  return options;
}

fs::path batch_out_path(const BatchCli& cli, const pt::Scenario& base) {
  return cli.out.empty() ? fs::path("out") / (base.name + "-batch") : fs::path(cli.out);
}

// Writes batch.json and batch.csv and prints the summary; `job` (the ranks' figures) is null in one process.
// `cap`: threads_cap_note of the run's --threads ("" when not capped).
int finish_batch(const pt::BatchResult& result, const pt::Scenario& base, OutputDir& out, const pt::BatchOnRanks* job,
                 const std::string& cap) {
  const fs::path json_path = out.path() / "batch.json", csv_path = out.path() / "batch.csv";
  pt::write_batch_csv(result, csv_path.string());
  pt::write_batch_json(result, base.name, json_path.string());
  out.commit();

  int failed = 0;
  for (const pt::SheetOutcome& o : result.outcomes) failed += o.status != "ok";
  const std::string workers = result.ranks > 1 ? plural(result.ranks, "rank") + " x " + plural(result.threads, "thread")
                                               : plural(result.threads, "thread");
  std::printf("%s: %s x %s on %s%s%s%s in %.3f s, %.1f sheet-frames/s, %d failed\n", base.name.c_str(),
              plural(result.sheets, "sheet").c_str(), plural(result.frames, "frame").c_str(), workers.c_str(),
              cap.empty() ? "" : " (", cap.c_str(), cap.empty() ? "" : ")", result.wall_s, result.sheet_frames_per_s,
              failed);
  if (job && result.ranks > 1) {
    // How the sheets were spread, and what coordinating them cost rank 0.
    std::string sheets, seconds;
    for (const pt::RankLoad& l : job->loads) {
      sheets += (sheets.empty() ? "" : " ") + std::to_string(l.sheets);
      char s[32];
      std::snprintf(s, sizeof s, "%s%.2f", seconds.empty() ? "" : " ", l.sheet_s);
      seconds += s;
    }
    const double n = std::max(1, result.sheets);
    const double remote = std::max(1, result.sheets - job->loads.front().sheets);
    std::printf("ranks: sheets %s; sheet time %s s; rank 0 coordinating %.1f us CPU per sheet; %.2f messages, "
                "%.0f B per sheet of the other ranks\n",
                sheets.c_str(), seconds.c_str(), 1e6 * job->coordinator_cpu_s / n, job->messages / remote,
                job->bytes / remote);
  }
  std::printf("wrote %s\nwrote %s\n", json_path.string().c_str(), csv_path.string().c_str());
  std::fflush(stdout);
  for (const pt::SheetOutcome& o : result.outcomes)
    if (o.status != "ok") {
      print_error("batch sheet " + std::to_string(o.index) + ": " + o.status);
      return kExitInternal;
    }
  return kExitOk;
}

// The exit status and the one line for the exception being handled.
struct Failure {
  int status = kExitOk;
  std::string message;
};
Failure describe_current_exception(const std::string& scenario_file) {
  try {
    throw;
  } catch (const pt::InputError& e) {
    return {kExitInput, e.what()};
  } catch (const pt::GeometryError& e) {
    // Geometry messages name the problem; the file is ours to add.
    return {kExitInput, scenario_file + ": " + e.what()};
  } catch (const UsageError& e) {
    return {kExitInput, e.what()};
  } catch (const OutputError& e) {
    return {kExitInternal, e.what()};
  } catch (const std::exception& e) {
    return {kExitInternal, std::string("internal error: ") + e.what()};
  } catch (...) {
    return {kExitInternal, "internal error: unknown exception"};
  }
}

// The batch on the ranks of an MPI job. Every rank reads the scenario and checks its share of the sheets
// (rank r: sheets r, r + N, …), rank 0 then the output directory; the job reports the failure one process
// would have reported first (the rank that found it prints the line) and every rank exits with its status,
// before anything is written. Then the sheets run on every rank and rank 0 writes the files.
int batch_command_on_ranks(const BatchCli& cli, const pt::BatchRanks& ranks) {
  std::optional<pt::Scenario> base;
  pt::BatchOptions options;
  std::optional<OutputDir> out;
  int32_t key = pt::kNoFailure;
  Failure failure;
  try {
    check_out_given(cli.out_given, cli.out);
    base = pt::load_scenario(cli.scenario, cli.settings);
    options = batch_options(cli);
    pt::check_batch_threads(options);
    int32_t largest = 0;
    for (int32_t i = ranks.rank; i < options.sheets && key == pt::kNoFailure; i += ranks.size) {
      try {
        pt::validate_batch_sheet(*base, options, i);
        largest = std::max(largest, pt::batch_sheet_scenario(*base, options, i).triangles);
      } catch (...) {
        key = i;
        failure = describe_current_exception(cli.scenario);
      }
    }
    if (key == pt::kNoFailure) {
      try {
        pt::check_batch_memory(std::min(options.sheets, options.threads), largest);  // this rank's machine
      } catch (...) {
        key = options.sheets;
        failure = describe_current_exception(cli.scenario);
      }
    }
    if (ranks.rank == 0 && key == pt::kNoFailure) {
      try {
        out.emplace(batch_out_path(cli, *base));
        out->create();
      } catch (...) {
        key = options.sheets;  // one process checks the directory after the sheets
        failure = describe_current_exception(cli.scenario);
      }
    }
  } catch (...) {
    key = -1;
    failure = describe_current_exception(cli.scenario);
  }
  const pt::RankFailure first = pt::first_failure_on_ranks(ranks, key, failure.status);
  if (first.key != pt::kNoFailure) {
    if (first.rank == ranks.rank) report_error(failure.message);
    return first.exit_status;
  }

  pt::BatchOnRanks job;
  try {
    // mpirun passes rank 0's stderr through a pipe: the bar goes to the terminal mpirun was started from,
    // when it runs on this host.
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> tty(nullptr, std::fclose);
    if (ranks.rank == 0 && ::isatty(STDERR_FILENO) != 1) tty.reset(std::fopen("/dev/tty", "w"));
    std::FILE* stream = ranks.rank != 0 ? nullptr : ::isatty(STDERR_FILENO) == 1 ? stderr : tty.get();
    Progress progress(options.sheets, stream);
    job = pt::run_batch_on_ranks(ranks, *base, options, [&](int32_t done, int32_t) { progress.update(done); });
  } catch (...) {
    // The other ranks wait for this one: the job ends.
    const Failure f = describe_current_exception(cli.scenario);
    report_error(f.message);
    pt::abort_ranks(f.status);
  }
  if (ranks.rank != 0) return kExitOk;
  return finish_batch(job.result, *base, *out, &job, pt::threads_cap_note({cli.threads, job.result.threads}));
}

int batch_command(const BatchCli& cli, const pt::BatchRanks& ranks) {
  if (ranks.size > 1) return batch_command_on_ranks(cli, ranks);
  if (!pt::batch_mpi_built() && pt::launcher_ranks().size > 1)
    throw UsageError("batch: this papertear was built without MPI (libopenmpi-dev), so each of the " +
                     std::to_string(pt::launcher_ranks().size) + " processes mpirun started would run the whole batch");
  check_out_given(cli.out_given, cli.out);
  const pt::Scenario base = pt::load_scenario(cli.scenario, cli.settings);
  const pt::BatchOptions options = batch_options(cli);
  // Every sheet's variation is checked before any runs, so a bad --vary range fails fast with exit 2.
  int32_t largest = 0;
  for (int32_t i = 0; i < options.sheets; ++i) {
    pt::validate_batch_sheet(base, options, i);
    largest = std::max(largest, pt::batch_sheet_scenario(base, options, i).triangles);
  }
  pt::check_batch_memory(std::min(options.sheets, options.threads), largest);
  OutputDir out(batch_out_path(cli, base));
  out.create();  // before the sheets run: a bad --out fails fast

  pt::BatchResult result;
  {
    Progress progress(options.sheets);
    std::mutex mutex;
    result = pt::run_batch(base, options, [&](int32_t done, int32_t) {
      const std::lock_guard<std::mutex> lock(mutex);
      progress.update(done);
    });
  }
  return finish_batch(result, base, out, nullptr, pt::threads_cap_note({cli.threads, result.threads}));
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"papertear: paper torn by fingers (Schreck et al., Interactive paper tearing, EG 2017)"};
  app.set_version_flag("--version", std::string("papertear ") + pt::version());
  app.require_subcommand(1);
  g_quiet = pt::launcher_ranks().rank > 0;

  RunOptions run;
  CLI::App* run_cmd = app.add_subcommand("run", "simulate a scenario and write DIR/result.json");
  run_cmd->add_option("SCENARIO", run.scenario, "scenario file (JSON)")->required();
  const char* set_help =
      "KEY=VALUE written into the scenario's JSON before it is read, e.g. sim.relaxation=patch (repeatable)";
  run_cmd->add_option("--set", run.settings, set_help);
  CLI::Option* run_out = run_cmd->add_option("--out", run.out, "output directory (default: out/<name>)");
  run_cmd->add_option("--frames", run.frames, "frames to simulate (default: the scenario's)")
      ->check(CLI::Range(1, 10'000'000));
  run_cmd->add_option("--threads", run.threads, "worker threads (default: 2)")->check(CLI::Range(1, pt::kMaxThreads));
  run_cmd->add_flag("--obj", run.obj, "write DIR/frames/frame_NNNN.obj + .mtl for every frame (textured: paper.png, carved_NNNN.png)");
  run_cmd->add_flag("--svg", run.svg, "write DIR/pattern.svg (mesh, regions, candidates, fingers, tears)");
  run_cmd->add_flag("--png", run.png, "write DIR/pattern.png (the pattern with detailed tears at texture resolution)");

  std::string check_path;
  std::vector<std::string> check_settings;
  CLI::App* check_cmd = app.add_subcommand("check", "validate a scenario only");
  check_cmd->add_option("SCENARIO", check_path, "scenario file (JSON)")->required();
  check_cmd->add_option("--set", check_settings, set_help);

  BatchCli batch;
  CLI::App* batch_cmd = app.add_subcommand("batch", "simulate N variations of a scenario in parallel (under mpirun -np N: over N processes)");
  batch_cmd->add_option("SCENARIO", batch.scenario, "scenario file (JSON)")->required();
  batch_cmd->add_option("--sheets", batch.sheets, "number of sheets")->required()->check(CLI::Range(1, 1'000'000));
  batch_cmd->add_option("--set", batch.settings, set_help);
  batch_cmd->add_option("--threads", batch.threads, "worker threads (default: 2)")->check(CLI::Range(1, pt::kMaxThreads));
  batch_cmd->add_option("--frames", batch.frames, "frames per sheet (default: the scenario's)")
      ->check(CLI::Range(1, 10'000'000));
  CLI::Option* batch_out = batch_cmd->add_option("--out", batch.out, "output directory (default: out/<name>-batch)");
  std::string vary_help = "KEY=FROM:TO, spread linearly over the sheets (repeatable); KEY is one of";
  for (const std::string& k : pt::variation_keys()) vary_help += " " + k;
  batch_cmd->add_option("--vary", batch.vary, vary_help);
  batch_cmd->add_flag("--fixed-seeds", batch.fixed_seeds,
                      "every sheet keeps the scenario's fibre and mesh seeds: a sweep varies only what --vary names");

  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {  // --help, --version
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    print_error(e.what());
    return kExitInput;
  }
  // PAPERTEAR_DENSE_KERNELS=avx2 or =baseline forces that build of the factorisations' kernels
  // (docs/architecture.md "Physics"); the library reads no environment, so it is passed on from here.
  if (const char* forced = std::getenv("PAPERTEAR_DENSE_KERNELS"); forced && *forced) {
    pt::DenseKernelChoice choice;
    if (!pt::dense_kernel_choice_from_name(forced, choice)) {
      print_error(std::string("PAPERTEAR_DENSE_KERNELS: unknown build \"") + forced + "\" (avx2 or baseline)");
      return kExitInput;
    }
    pt::select_dense_kernels(choice);
  }

  run.out_given = run_out->count() > 0;
  batch.out_given = batch_out->count() > 0;
  // MPI runs only for a batch, and only under a launcher (mpirun, srun); finalized after the last line.
  std::optional<pt::BatchMpi> mpi;
  try {
    if (*run_cmd) return run_command(run);
    if (*check_cmd) return check_command(check_path, check_settings);
    if (*batch_cmd) {
      mpi.emplace();
      return batch_command(batch, mpi->ranks());
    }
    print_error("no command (run, check or batch)");
    return kExitInput;
  } catch (const Interrupted& e) {
    // The output is cleaned up (run_command has unwound); end as the signal would have.
    print_error(e.what());
    std::signal(e.signal, SIG_DFL);
    std::raise(e.signal);
    return 128 + e.signal;
  } catch (...) {
    const std::string& file = *run_cmd ? run.scenario : *check_cmd ? check_path : batch.scenario;
    const Failure f = describe_current_exception(file);
    print_error(f.message);
    return f.status;
  }
}
