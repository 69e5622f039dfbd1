// `mpirun -np N papertear batch` (issue 26, engine/batch_mpi.hpp): the sheets' runs cross between ranks
// unchanged, rank 0's ranges cover every sheet once, and 2 or 3 ranks write the batch.json and batch.csv
// of one process ("ranks" and the timings aside); a rank that finds an invalid sheet ends the job with exit 2, one line and
// no files; a sheet that fails on a rank does not lose the others'.
#include "engine/batch_mpi.hpp"

#include "command_line.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

using namespace pt;

const std::string kBinary = std::string(PT_BINARY_DIR) + "/bin/papertear";
const std::string kDriver = std::string(PT_BINARY_DIR) + "/bin/batch_mpi_driver";

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kAsan = true;
#elif defined(__has_feature)
constexpr bool kAsan = __has_feature(address_sanitizer);
#else
constexpr bool kAsan = false;
#endif

SheetRun sample_run(int32_t index) {
  SheetRun run;
  run.outcome.index = index;
  run.outcome.fiber_seed = 0xFEDCBA9876543210ull + index;
  run.outcome.mesh_seed = 7;
  run.outcome.varied = {0.1 * index, -3e-300, 1.0 / 3.0};
  run.outcome.triangles = 312 + index;
  run.outcome.tear_length = 0.0123456789012345;
  run.outcome.tears = 2;
  run.outcome.pieces = 3;
  run.outcome.max_finger_force = 4.5e-7;
  run.outcome.frame_ms = 1.25;
  run.outcome.hash = "9f86d081884c7d65";
  run.outcome.status = index % 2 ? "error: the solver refused 30 of the run's 30 substeps" : "ok";
  for (size_t k = 0; k < run.systems.size(); ++k) run.systems[k] = {0.5 * k + index, 0.25 * k, int64_t(k) * 3};
  run.frames_timed = 60;
  run.bytes = 123456789012ull;
  run.solver_bytes = 99;
  run.triangles = 18720.5;
  return run;
}

void expect_same(const SheetRun& a, const SheetRun& b) {
  EXPECT_EQ(a.outcome.index, b.outcome.index);
  EXPECT_EQ(a.outcome.fiber_seed, b.outcome.fiber_seed);
  EXPECT_EQ(a.outcome.mesh_seed, b.outcome.mesh_seed);
  EXPECT_EQ(a.outcome.varied, b.outcome.varied);  // bit for bit
  EXPECT_EQ(a.outcome.triangles, b.outcome.triangles);
  EXPECT_EQ(a.outcome.tear_length, b.outcome.tear_length);
  EXPECT_EQ(a.outcome.tears, b.outcome.tears);
  EXPECT_EQ(a.outcome.pieces, b.outcome.pieces);
  EXPECT_EQ(a.outcome.max_finger_force, b.outcome.max_finger_force);
  EXPECT_EQ(a.outcome.frame_ms, b.outcome.frame_ms);
  EXPECT_EQ(a.outcome.hash, b.outcome.hash);
  EXPECT_EQ(a.outcome.status, b.outcome.status);
  for (size_t k = 0; k < a.systems.size(); ++k) {
    EXPECT_EQ(a.systems[k].sum, b.systems[k].sum) << k;
    EXPECT_EQ(a.systems[k].max, b.systems[k].max) << k;
    EXPECT_EQ(a.systems[k].count, b.systems[k].count) << k;
  }
  EXPECT_EQ(a.frames_timed, b.frames_timed);
  EXPECT_EQ(a.bytes, b.bytes);
  EXPECT_EQ(a.solver_bytes, b.solver_bytes);
  EXPECT_EQ(a.triangles, b.triangles);
}

TEST(BatchMpi, SheetRunsCrossTheWireUnchanged) {
  const std::vector<SheetRun> runs = {sample_run(4), sample_run(5), sample_run(6)};
  const std::vector<SheetRun> back = decode_sheet_runs(encode_sheet_runs(runs));
  ASSERT_EQ(back.size(), runs.size());
  for (size_t i = 0; i < runs.size(); ++i) expect_same(back[i], runs[i]);
  EXPECT_TRUE(decode_sheet_runs(encode_sheet_runs({})).empty());  // a rank's first request carries none
}

TEST(BatchMpi, AMalformedMessageIsRefused) {
  const std::string bytes = encode_sheet_runs({sample_run(1)});
  for (const size_t cut : {size_t{0}, size_t{3}, size_t{8}, bytes.size() / 2, bytes.size() - 1})
    EXPECT_THROW(decode_sheet_runs(std::string_view(bytes).substr(0, cut)), std::runtime_error) << cut;
  EXPECT_THROW(decode_sheet_runs(bytes + "x"), std::runtime_error);
  std::string other = bytes;
  other[0] ^= 1;
  EXPECT_THROW(decode_sheet_runs(other), std::runtime_error);
}

// Rank 0's ranges: contiguous, every sheet once, never more than 8 per thread nor fewer than a thread's
// one (but for the last), and shrinking to single sheets as the batch ends.
TEST(BatchMpi, RangesCoverEverySheetOnceAndShrink) {
  for (const int32_t ranks : {2, 3, 64})
    for (const int32_t threads : {1, 2})
      for (const int32_t sheets : {1, 5, 100, 10000}) {
        int32_t next = 0, last = INT32_MAX, ranges = 0;
        for (;;) {
          const SheetRange r = next_sheet_range(next, sheets, ranks, threads);
          if (r.count == 0) break;
          ASSERT_EQ(r.first, next);
          EXPECT_LE(r.count, 8 * threads);
          EXPECT_LE(r.count, last);
          EXPECT_TRUE(r.count >= threads || next + r.count == sheets);
          last = r.count;
          next += r.count;
          ++ranges;
        }
        EXPECT_EQ(next, sheets) << ranks << " " << threads << " " << sheets;
        EXPECT_LE(last, threads);
        if (sheets == 10000) {
          EXPECT_LT(ranges, sheets / (4 * threads)) << ranks;  // few messages per sheet
        }
      }
  EXPECT_EQ(next_sheet_range(7, 7, 2, 1).count, 0);
}

using pt_test::quote;
using pt_test::read_file;
using pt_test::Result;

class BatchMpiRanks : public ::testing::Test {
 protected:
  void SetUp() override {
#ifndef PT_MPIEXEC
    GTEST_SKIP() << "built without MPI (libopenmpi-dev): a batch runs in one process";
#endif
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("pt_batch_mpi_test_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    ASSERT_TRUE(fs::exists(kBinary)) << kBinary << " not built";
  }
  void TearDown() override {
    if (!HasFailure() && !dir_.empty()) fs::remove_all(dir_);
  }

  // `ranks` 0: the program alone, without mpirun.
  Result run(int ranks, const std::string& program, const std::vector<std::string>& args) {
    std::string cmd;
#ifdef PT_MPIEXEC
    if (ranks > 0) {
      // Open MPI keeps allocations of its components until exit and unloads them, so LeakSanitizer reports
      // frames it cannot name (and no suppression can): in the ASan build the ranks run without leak
      // checking, address and UB checks on (Open MPI 4.1).
      if (kAsan) cmd += "ASAN_OPTIONS=\"${ASAN_OPTIONS:-}:detect_leaks=0\" ";
      // -q: no banner of mpirun's own when a rank exits with status 2, so stderr is papertear's line.
      cmd += "timeout 120 " + quote(PT_MPIEXEC) + " --allow-run-as-root --oversubscribe -q -np " + std::to_string(ranks) + " ";
    } else {
      cmd += "timeout 120 ";
    }
#endif
    cmd += quote(program);
    for (const std::string& a : args) {  // piece by piece: GCC 12's false -Wrestrict on " " + std::string&&
      cmd += " ";
      cmd += quote(a);
    }
    return pt_test::run_in(dir_, cmd);
  }

  std::vector<std::string> listing() { return pt_test::listing(dir_); }

  fs::path dir_;
};

// batch.csv without the frame-time column (a timing) and batch.json's outcomes without frame_ms.
std::vector<std::string> csv_without_times(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> rows;
  for (std::string line; std::getline(in, line);) {
    std::istringstream l(line);
    std::string c, row;
    for (size_t i = 0; std::getline(l, c, ','); ++i)
      if (i != 8) row += c + ",";  // frame_ms
    rows.push_back(row);
  }
  return rows;
}

nlohmann::json outcomes_without_times(nlohmann::json outcomes) {
  for (auto& o : outcomes) o.erase("frame_ms");
  return outcomes;
}

// Sheets of different cost (the substeps spread 2 → 12 over the batch), torn from the border inward.
TEST_F(BatchMpiRanks, TwoAndThreeRanksWriteWhatOneProcessWrites) {
  const std::vector<std::string> batch = {"batch", std::string(PT_SOURCE_DIR) + "/scenarios/start-inward.json",
                                          "--sheets", "7", "--frames", "12", "--threads", "1", "--set",
                                          "sheet.triangles=120", "--vary", "sim.substeps=2:12", "--vary",
                                          "detail.sigma=1e-4:3e-4"};
  auto with_out = [&](const std::string& out) {
    std::vector<std::string> a = batch;
    a.insert(a.end(), {"--out", out});
    return a;
  };
  const Result one = run(0, kBinary, with_out("one"));
  ASSERT_EQ(one.status, 0) << one.err;
  const nlohmann::json a = nlohmann::json::parse(read_file(dir_ / "one" / "batch.json"));
  EXPECT_FALSE(a.contains("ranks"));  // one process writes the batch.json it always wrote
  for (const int ranks : {2, 3}) {
    const std::string out = "np" + std::to_string(ranks);
    const Result r = run(ranks, kBinary, with_out(out));
    ASSERT_EQ(r.status, 0) << ranks << " ranks:\n" << r.err;
    EXPECT_EQ(r.err, "") << ranks;
    EXPECT_NE(r.out.find("on " + std::to_string(ranks) + " ranks x 1 thread"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("rank 0 coordinating "), std::string::npos) << r.out;
    const nlohmann::json b = nlohmann::json::parse(read_file(dir_ / out / "batch.json"));
    EXPECT_EQ(b["ranks"], ranks);
    EXPECT_EQ(b["hashes"], a["hashes"]) << ranks;
    EXPECT_EQ(outcomes_without_times(b["outcomes"]), outcomes_without_times(a["outcomes"])) << ranks;
    for (const char* key : {"sheets", "threads", "frames", "vary", "bytes_per_sheet", "solver_bytes_per_sheet"})
      EXPECT_EQ(b[key], a[key]) << key;
    for (const auto& [name, t] : a["throughput"].items()) EXPECT_EQ(b["throughput"][name]["calls"], t["calls"]) << name;
    EXPECT_EQ(csv_without_times(read_file(dir_ / out / "batch.csv")),
              csv_without_times(read_file(dir_ / "one" / "batch.csv")));
  }
  // One rank under mpirun is the plain batch.
  const Result single = run(1, kBinary, with_out("np1"));
  ASSERT_EQ(single.status, 0) << single.err;
  const nlohmann::json c = nlohmann::json::parse(read_file(dir_ / "np1" / "batch.json"));
  EXPECT_FALSE(c.contains("ranks"));
  EXPECT_EQ(c["hashes"], a["hashes"]);
}

// Sheet 1 of 3 (Poisson's ratio 0.5) is invalid: with 2 and 3 ranks it is rank 1's to check (sheets go
// round-robin to the checks), and rank 1 reports it. The job ends before anything is written, with the
// line one process prints; a scenario that does not load is one line too, not one per rank.
TEST_F(BatchMpiRanks, ARankThatFindsAnInvalidSheetEndsTheJobWithStatus2) {
  const fs::path scenario = fs::path(PT_SOURCE_DIR) / "scenarios" / "start-inward.json";
  const std::vector<std::string> bad = {"batch", scenario.string(), "--sheets", "3", "--frames", "2",
                                        "--vary", "material.poisson=0.3:0.7", "--out", "bad"};
  const Result one = run(0, kBinary, bad);
  ASSERT_EQ(one.status, 2) << one.err;
  ASSERT_NE(one.err.find("(batch sheet 1)"), std::string::npos) << one.err;
  for (const int ranks : {2, 3}) {
    const Result r = run(ranks, kBinary, bad);
    EXPECT_EQ(r.status, 2) << ranks << " ranks:\n" << r.err;
    EXPECT_EQ(r.err, one.err) << ranks;
    EXPECT_EQ(r.out, "") << ranks;
    EXPECT_TRUE(listing().empty()) << ranks << " ranks left " << listing().front();
  }
  std::ofstream(dir_ / "broken.json") << "{\"name\": \"x\", \"sheet\": ";
  const Result broken_one = run(0, kBinary, {"batch", "broken.json", "--sheets", "4", "--out", "b"});
  ASSERT_EQ(broken_one.status, 2);
  const Result broken = run(3, kBinary, {"batch", "broken.json", "--sheets", "4", "--out", "b"});
  EXPECT_EQ(broken.status, 2) << broken.err;
  EXPECT_EQ(broken.err, broken_one.err);
  EXPECT_FALSE(fs::exists(dir_ / "b"));
}

// Sheets 2 and 3 of 4 fail as they start (tests/engine/batch_mpi_driver.cpp: an invalid Poisson's ratio, which the
// command line would refuse before any sheet ran): their outcomes say so, whichever rank ran them, and the
// others' stay, the same with 2 ranks as in one process.
TEST_F(BatchMpiRanks, ASheetThatFailsKeepsTheOthers) {
  ASSERT_TRUE(fs::exists(kDriver)) << kDriver << " not built";
  const std::string scenario = std::string(PT_SOURCE_DIR) + "/scenarios/start-inward.json";
  const Result one = run(0, kDriver, {scenario, "one.json"});
  ASSERT_EQ(one.status, 0) << one.err;
  const Result two = run(2, kDriver, {scenario, "two.json"});
  ASSERT_EQ(two.status, 0) << two.err;
  const nlohmann::json a = nlohmann::json::parse(read_file(dir_ / "one.json"));
  const nlohmann::json b = nlohmann::json::parse(read_file(dir_ / "two.json"));
  EXPECT_EQ(b["ranks"], 2);
  ASSERT_EQ(b["outcomes"].size(), 4u);
  for (const int i : {0, 1}) EXPECT_EQ(b["outcomes"][i]["status"], "ok") << i;
  for (const int i : {2, 3}) {
    const std::string status = b["outcomes"][i]["status"];
    EXPECT_EQ(status.rfind("error: ", 0), 0u) << status;
    EXPECT_NE(status.find("material.poisson"), std::string::npos) << status;
    EXPECT_EQ(b["hashes"][i], "") << i;
  }
  EXPECT_NE(b["hashes"][1], "");
  EXPECT_EQ(b["hashes"], a["hashes"]);
  EXPECT_EQ(outcomes_without_times(b["outcomes"]), outcomes_without_times(a["outcomes"]));
}

}  // namespace
