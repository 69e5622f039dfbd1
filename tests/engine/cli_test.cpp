// The papertear command line as a user meets it (docs/result-format.md): exit status 2 with exactly one line
// on stderr and nothing written for every bad input; exit 0, a complete result.json and an SVG for a good
// one; usage errors are exit 2 too.
#include "engine/scenario.hpp"
#include "engine/texture_export.hpp"

#include "command_line.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <fcntl.h>
#include <oneapi/tbb/info.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <thread>
#include <cstdio>
#include <cmath>
#include <array>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

const std::string kBinary = std::string(PT_BINARY_DIR) + "/bin/papertear";
const std::string kViewer = std::string(PT_BINARY_DIR) + "/bin/papertear-viewer";
const std::string kBadDir = std::string(PT_SOURCE_DIR) + "/tests/data/bad";

// A small sheet that runs in well under a second: A6, 60 triangles, 3 frames, two fingers pulling up.
const char* kGood = R"({
  "name": "cli-good",
  "sheet": {"preset": "A6", "triangles": 60},
  "sim": {"frames": 3},
  "fingers": [
    {"name": "A", "at": [0.02, 0.14], "keys": [[0, [0.02, 0.14, 0]], [1, [0.02, 0.16, 0.02]]]},
    {"name": "B", "at": [0.085, 0.14], "keys": [[0, [0.085, 0.14, 0]], [1, [0.085, 0.16, 0.02]]]}
  ]
})";

using pt_test::quote;
using pt_test::read_file;
using pt_test::Result;
using pt_test::write_file;

// Each test works in its own empty directory (the default output dir is relative: out/<name>).
class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("pt_cli_test_" + std::to_string(::getpid()) + "_" + info->test_suite_name() + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    ASSERT_TRUE(fs::exists(kBinary)) << kBinary << " not built";
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(dir_);
  }

  Result run(const std::vector<std::string>& args) { return run_program(kBinary, args); }

  // `env` goes before the command: "env -u DISPLAY" runs it without a display.
  Result run_program(const std::string& binary, const std::vector<std::string>& args, const std::string& env = "") {
    // timeout(1): a hang becomes a failure (status 124) instead of stalling the suite.
    std::string cmd = env;
    cmd += " timeout 120 ";
    cmd += quote(binary);
    for (const std::string& a : args) {
      cmd += " ";
      cmd += quote(a);
    }
    return pt_test::run_in(dir_, cmd);
  }

  fs::path good() {
    const fs::path p = dir_ / "good.json";
    write_file(p, kGood);
    return p;
  }

  // Everything in the working directory (the run must have created nothing).
  std::vector<std::string> listing() { return pt_test::listing(dir_); }

  fs::path dir_;
};

bool one_line(const std::string& s) { return !s.empty() && s.back() == '\n' && std::count(s.begin(), s.end(), '\n') == 1; }

void expect_input_error(const Result& r, const std::string& what) {
  EXPECT_EQ(r.status, 2) << what << "\nstderr: " << r.err;
  EXPECT_TRUE(one_line(r.err)) << what << ": stderr is not exactly one line:\n" << r.err;
  EXPECT_EQ(r.err.rfind("papertear: ", 0), 0u) << r.err;
}

// ---- bad input: every fixture, with run and check ----

TEST_F(Cli, EveryBadFixtureIsExit2OneLineNoOutput) {
  int count = 0;
  for (const auto& entry : fs::directory_iterator(kBadDir)) {
    const std::string file = entry.path().string();
    SCOPED_TRACE(file);
    const Result r = run({"run", file, "--out", "result-dir", "--svg", "--obj"});
    expect_input_error(r, "run " + file);
    EXPECT_NE(r.err.find(file), std::string::npos) << "the message does not name the file: " << r.err;
    EXPECT_TRUE(listing().empty()) << "output written for a bad input";
    const Result c = run({"check", file});
    expect_input_error(c, "check " + file);
    ++count;
  }
  EXPECT_GE(count, 20);
}

TEST_F(Cli, BinaryGarbageIsExit2) {
  std::string bytes;
  for (int i = 0; i < 4096; ++i) bytes += static_cast<char>((i * 131 + 7) & 0xff);
  write_file(dir_ / "garbage.json", bytes);
  const Result r = run({"run", "garbage.json"});
  expect_input_error(r, "garbage");
  EXPECT_NE(r.err.find("garbage.json"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir_ / "out"));
}

TEST_F(Cli, InvalidUtf8WithoutNulIsExit2) {
  std::string bytes = "{\"name\": \"";
  for (int i = 0; i < 300; ++i) bytes += static_cast<char>(0x80 | (i & 0x7f));
  write_file(dir_ / "latin.json", bytes + "\"}\n");
  const Result r = run({"check", "latin.json"});
  expect_input_error(r, "invalid utf-8");
}

TEST_F(Cli, MissingFileAndDirectoryAreExit2) {
  expect_input_error(run({"run", "nope.json"}), "missing file");
  fs::create_directories(dir_ / "adir");
  expect_input_error(run({"check", "adir"}), "directory");
  EXPECT_FALSE(fs::exists(dir_ / "out"));
}

// ---- usage errors ----

// papertear-self-intersections (issue 25's measure) takes the scenario's --set like papertear run, checks
// after every substep with --substeps (frames x substeps states when nothing stops for tearing), and
// refuses a bad setting with one line naming the file.
TEST_F(Cli, SelfIntersectionsChecksEverySubstepWithTheSettingsGiven) {
  const std::string tool = std::string(PT_BINARY_DIR) + "/bin/papertear-self-intersections";
  const std::string file = good().string();
  const Result r = run_program(tool, {file, "--substeps", "--set", "sim.substeps=4"});
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("largest 0 intersecting pairs; 0 of 12 checked substeps have some"), std::string::npos) << r.out;
  const Result frames = run_program(tool, {file, "--every", "1"});
  EXPECT_NE(frames.out.find("0 of 3 checked frames have some"), std::string::npos) << frames.out;
  const Result bad = run_program(tool, {file, "--set", "sim.substeps=-1"});
  EXPECT_EQ(bad.status, 2);
  EXPECT_TRUE(one_line(bad.err)) << bad.err;
  EXPECT_NE(bad.err.find(file), std::string::npos) << bad.err;
  EXPECT_EQ(run_program(tool, {file, "--set"}).status, 2) << "a missing value";
}

TEST_F(Cli, UsageErrorsAreExit2OneLine) {
  const fs::path g = good();
  expect_input_error(run({}), "no subcommand");
  expect_input_error(run({"fly", g.string()}), "unknown subcommand");
  expect_input_error(run({"run"}), "missing scenario");
  expect_input_error(run({"run", g.string(), "--bogus"}), "unknown flag");
  expect_input_error(run({"run", g.string(), "--threads", "0"}), "--threads 0");
  expect_input_error(run({"run", g.string(), "--threads", "two"}), "--threads two");
  expect_input_error(run({"run", g.string(), "--frames", "-1"}), "--frames -1");
  expect_input_error(run({"run", g.string(), "--frames", "0"}), "--frames 0");
  expect_input_error(run({"batch", g.string()}), "batch without --sheets");
  expect_input_error(run({"batch", g.string(), "--sheets", "2", "--vary", "material.colour=1:2"}), "bad --vary");
  expect_input_error(run({"batch", g.string(), "--sheets", "3", "--vary", "material.poisson=0.3:0.7"}),
                     "--vary out of range");
  EXPECT_FALSE(fs::exists(dir_ / "out"));
}

TEST_F(Cli, OutIsAFileIsExit2) {
  const fs::path g = good();
  write_file(dir_ / "taken", "x");
  expect_input_error(run({"run", g.string(), "--out", "taken"}), "--out is a file");
  EXPECT_EQ(read_file(dir_ / "taken"), "x");
}

TEST_F(Cli, HelpIsExit0) {
  const Result r = run({"--help"});
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.out.find("run"), std::string::npos);
}

// ---- good input ----

TEST_F(Cli, CheckGoodScenario) {
  const Result r = run({"check", good().string()});
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << r.err;
  EXPECT_NE(r.out.find("ok"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir_ / "out"));
}

TEST_F(Cli, RunWritesEveryResultKey) {
  const Result r = run({"run", good().string(), "--svg"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << "stderr must stay quiet off a terminal: " << r.err;
  EXPECT_NE(r.out.find("3 frames"), std::string::npos) << r.out;

  const fs::path out = dir_ / "out" / "cli-good";  // default DIR: out/<name>
  const nlohmann::json j = nlohmann::json::parse(read_file(out / "result.json"));
  for (const char* key : {"scenario", "status", "frames", "threads", "mesh", "tears", "fingers", "timings_ms", "hash"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j["scenario"], "cli-good");
  EXPECT_EQ(j["status"], "ok");
  EXPECT_EQ(j["frames"], 3);
  EXPECT_EQ(j["threads"], 2);
  for (const char* key : {"vertices", "triangles", "triangles_avg", "triangles_max", "pieces"})
    EXPECT_TRUE(j["mesh"].contains(key)) << "mesh." << key;
  EXPECT_TRUE(j["mesh"]["triangles"].is_number_integer());
  ASSERT_TRUE(j["tears"].is_array());
  for (const auto& t : j["tears"]) {
    for (const char* key : {"id", "parent", "start", "tips", "detail"}) EXPECT_TRUE(t.contains(key)) << "tears[]." << key;
    EXPECT_TRUE(t["parent"].is_null() || t["parent"].is_number_integer());
    for (const char* key : {"kind", "frame", "uv"}) EXPECT_TRUE(t["start"].contains(key)) << "tears[].start." << key;
    const std::string kind = t["start"]["kind"];
    EXPECT_TRUE(kind == "finger" || kind == "junction" || kind == "inward") << kind;
    EXPECT_EQ(t["start"]["uv"].size(), 2u);
    for (const auto& p : t["tips"]) EXPECT_EQ(p.size(), 2u);
  }
  ASSERT_EQ(j["fingers"].size(), 2u);
  EXPECT_EQ(j["fingers"][0]["name"], "A");
  EXPECT_EQ(j["fingers"][1]["name"], "B");
  for (const auto& f : j["fingers"]) {
    EXPECT_EQ(f["uv"].size(), 2u);
    EXPECT_TRUE(f["max_force"].is_number());
  }
  for (const char* group : {"physics", "geometry", "tearing", "carving", "frame"}) {
    ASSERT_TRUE(j["timings_ms"].contains(group)) << group;
    EXPECT_TRUE(j["timings_ms"][group]["avg"].is_number()) << group;
    EXPECT_TRUE(j["timings_ms"][group]["max"].is_number()) << group;
  }
  EXPECT_TRUE(j["hash"].is_string());
  EXPECT_FALSE(j["hash"].get<std::string>().empty());
  for (const char* extra : {"systems_ms", "regions_summary", "pieces"}) EXPECT_TRUE(j.contains(extra)) << extra;
  EXPECT_EQ(j["systems_ms"].size(), 11u);
  // Solver work: the default implicit integrator factorises at least once per substep (3 frames here, the
  // scenario's substeps each) and analyses the structure at least once.
  ASSERT_TRUE(j.contains("solver"));
  for (const char* key : {"analyses", "factorizations", "brakes", "regularised", "failures", "remeshes"})
    EXPECT_TRUE(j["solver"][key].is_number_integer()) << "solver." << key;
  EXPECT_GE(j["solver"]["factorizations"].get<int>(), 3 * 10);
  EXPECT_GE(j["solver"]["analyses"].get<int>(), 1);
  EXPECT_EQ(j["solver"]["failures"].get<int>(), 0);
  // Where the solver's time went: every part ran at least once (wall times, ms over the run).
  ASSERT_TRUE(j.contains("solver_ms"));
  for (const char* key : {"structure", "analysis", "assembly", "factorization", "solve"}) {
    ASSERT_TRUE(j["solver_ms"][key].is_number()) << "solver_ms." << key;
    EXPECT_GT(j["solver_ms"][key].get<double>(), 0.0) << "solver_ms." << key;
  }

  // No NaN, no inf: the text parses as JSON (which has neither) and has no null numbers.
  const std::string text = read_file(out / "result.json");
  EXPECT_EQ(text.find("NaN"), std::string::npos);
  EXPECT_EQ(text.find("nan"), std::string::npos);

  const std::string svg = read_file(out / "pattern.svg");
  EXPECT_EQ(svg.rfind("<svg", 0), 0u) << svg.substr(0, 80);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  EXPECT_NE(svg.find(">A</text>"), std::string::npos);
  EXPECT_EQ(svg.find("nan"), std::string::npos);
}

TEST_F(Cli, ObjFramesAndNoLeftovers) {
  const Result r = run({"run", good().string(), "--out", "o", "--obj", "--frames", "2", "--threads", "1"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir_ / "o" / "frames" / "frame_0001.obj"));
  EXPECT_TRUE(fs::exists(dir_ / "o" / "frames" / "frame_0002.obj"));
  EXPECT_FALSE(fs::exists(dir_ / "o" / "frames" / "frame_0003.obj"));
  const std::string obj = read_file(dir_ / "o" / "frames" / "frame_0001.obj");
  EXPECT_NE(obj.find("\nv "), std::string::npos);
  EXPECT_NE(obj.find("\nvt "), std::string::npos);
  EXPECT_NE(obj.find("\nf "), std::string::npos);
  for (const auto& e : fs::directory_iterator(dir_ / "o")) {
    const std::string name = e.path().filename().string();
    EXPECT_TRUE(name == "result.json" || name == "frames") << "leftover " << name;
  }
  const nlohmann::json j = nlohmann::json::parse(read_file(dir_ / "o" / "result.json"));
  EXPECT_EQ(j["frames"], 2);
  EXPECT_EQ(j["threads"], 1);
}

// Issue 27, item 16: a run's frames replace an earlier run's in DIR/frames/, and a file the user keeps
// there is not deleted.
TEST_F(Cli, ObjFramesKeepTheUsersFiles) {
  fs::create_directories(dir_ / "o" / "frames");
  { std::ofstream(dir_ / "o" / "frames" / "my.txt") << "mine"; }
  { std::ofstream(dir_ / "o" / "frames" / "frame_0009.obj") << "an earlier run's"; }
  const Result r = run({"run", good().string(), "--out", "o", "--obj", "--frames", "2", "--threads", "1"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(read_file(dir_ / "o" / "frames" / "my.txt"), "mine");
  EXPECT_FALSE(fs::exists(dir_ / "o" / "frames" / "frame_0009.obj"));
  EXPECT_TRUE(fs::exists(dir_ / "o" / "frames" / "frame_0002.obj"));
  for (const auto& e : fs::directory_iterator(dir_ / "o"))
    EXPECT_EQ(e.path().filename().string().find(".frames.partial"), std::string::npos) << e.path();
}

TEST_F(Cli, SameHashAtOneAndTwoThreads) {
  const fs::path g = good();
  ASSERT_EQ(run({"run", g.string(), "--out", "t1", "--threads", "1"}).status, 0);
  ASSERT_EQ(run({"run", g.string(), "--out", "t2", "--threads", "2"}).status, 0);
  const auto h1 = nlohmann::json::parse(read_file(dir_ / "t1" / "result.json"))["hash"];
  const auto h2 = nlohmann::json::parse(read_file(dir_ / "t2" / "result.json"))["hash"];
  EXPECT_EQ(h1, h2);
}

TEST_F(Cli, BatchWritesBatchJson) {
  const Result r = run({"batch", good().string(), "--sheets", "3", "--frames", "2", "--out", "b"});
  ASSERT_EQ(r.status, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(read_file(dir_ / "b" / "batch.json"));
  for (const char* key : {"sheets", "threads", "wall_s", "sheet_frames_per_s", "timings_ms", "hashes"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j["sheets"], 3);
  EXPECT_EQ(j["hashes"].size(), 3u);
}

// A sweep is recorded per sheet: --vary spreads the key linearly from FROM (first sheet) to TO (last), and a
// sweep that leaves the key's valid range is an input error (here the patch relaxation's radius).
TEST_F(Cli, BatchVariesTheRelaxationRadius) {
  const Result r = run({"batch", good().string(), "--sheets", "3", "--frames", "2", "--vary",
                        "sim.relaxation_radius=0.02:0.06", "--out", "v"});
  ASSERT_EQ(r.status, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(read_file(dir_ / "v" / "batch.json"));
  ASSERT_EQ(j["outcomes"].size(), 3u);
  const double expected[3] = {0.02, 0.04, 0.06};
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(j["outcomes"][i]["varied"][0].get<double>(), expected[i], 1e-12) << i;
  expect_input_error(run({"batch", good().string(), "--sheets", "2", "--vary", "sim.relaxation_radius=0:0.05"}),
                     "--vary sim.relaxation_radius from 0");
}

// A sweep can be analysed: batch.json names what was varied and each sheet's values by key, batch.csv has a
// column per varied key, and --fixed-seeds keeps every sheet on the scenario's fibre and mesh seeds, so the
// sheets differ only in the varied key (its values equal: the same hash).
TEST_F(Cli, BatchNamesWhatItVariesAndCanKeepTheSeeds) {
  const Result r = run({"batch", good().string(), "--sheets", "3", "--frames", "2", "--vary",
                        "material.young=4e9:4e9", "--vary", "detail.sigma=1e-4:3e-4", "--fixed-seeds", "--out", "f"});
  ASSERT_EQ(r.status, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(read_file(dir_ / "f" / "batch.json"));
  ASSERT_EQ(j["vary"].size(), 2u);
  EXPECT_EQ(j["vary"][0]["key"], "material.young");
  EXPECT_EQ(j["vary"][1]["to"].get<double>(), 3e-4);
  EXPECT_TRUE(j["fixed_seeds"].get<bool>());
  ASSERT_EQ(j["outcomes"].size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(j["outcomes"][i]["fiber_seed"], j["outcomes"][0]["fiber_seed"]) << i;
    EXPECT_EQ(j["outcomes"][i]["mesh_seed"], j["outcomes"][0]["mesh_seed"]) << i;
    EXPECT_NEAR(j["outcomes"][i]["values"]["detail.sigma"].get<double>(), 1e-4 * (1 + i), 1e-15) << i;
  }
  // sigma shapes the carved details only: the coarse state, hence the hash, is the same for every sheet.
  EXPECT_EQ(j["hashes"][1], j["hashes"][0]);
  std::istringstream csv(read_file(dir_ / "f" / "batch.csv"));
  std::string header, row;
  std::getline(csv, header);
  EXPECT_NE(header.find(",status,material.young,detail.sigma"), std::string::npos) << header;
  std::getline(csv, row);
  std::getline(csv, row);
  EXPECT_NE(row.find(",0.0002"), std::string::npos) << row;
  // Without --fixed-seeds the sheets get their own seeds.
  const Result mixed = run({"batch", good().string(), "--sheets", "2", "--frames", "1", "--out", "m"});
  ASSERT_EQ(mixed.status, 0) << mixed.err;
  const nlohmann::json m = nlohmann::json::parse(read_file(dir_ / "m" / "batch.json"));
  EXPECT_NE(m["outcomes"][1]["mesh_seed"], m["outcomes"][0]["mesh_seed"]);
  EXPECT_NE(run({"batch", "--help"}).out.find("material.strain_limit"), std::string::npos);
}

// --set on run, check and batch: the setting is read as if it were in the file; a bad one is exit 2, one line.
TEST_F(Cli, SetWritesIntoTheScenario) {
  const fs::path g = good();
  const Result checked = run({"check", g.string(), "--set", "sim.frames=7", "--set", "sim.relaxation=patch"});
  ASSERT_EQ(checked.status, 0) << checked.err;
  EXPECT_NE(checked.out.find("7 frames"), std::string::npos) << checked.out;
  const Result ran = run({"run", g.string(), "--set", "sim.frames=3", "--out", "s"});
  ASSERT_EQ(ran.status, 0) << ran.err;
  EXPECT_EQ(nlohmann::json::parse(read_file(dir_ / "s" / "result.json"))["frames"], 3);
  const Result batch = run({"batch", g.string(), "--sheets", "2", "--set", "sim.frames=2", "--out", "sb"});
  ASSERT_EQ(batch.status, 0) << batch.err;
  EXPECT_EQ(nlohmann::json::parse(read_file(dir_ / "sb" / "batch.json"))["frames"], 2);
  expect_input_error(run({"run", g.string(), "--set", "sim.relaxation=nope", "--out", "bad"}), "--set bad value");
  expect_input_error(run({"check", g.string(), "--set", "novalue"}), "--set without =");
  EXPECT_FALSE(fs::exists(dir_ / "bad"));
}

// Issue 6: results identical at any --threads, not only the hashes: every per-sheet outcome (CSV, timing
// column aside) and the memory per sheet. A tearing scenario, so cuts (and the per-thread buffers of the
// local topology refresh) run on whichever worker takes a sheet.
TEST_F(Cli, BatchIsTheSameAtOneAndTwoThreads) {
  const std::string scenario = std::string(PT_SOURCE_DIR) + "/scenarios/start-inward.json";
  for (const char* t : {"1", "2"}) {
    const Result r = run({"batch", scenario, "--sheets", "4", "--frames", "30", "--threads", t, "--out", std::string("b") + t});
    ASSERT_EQ(r.status, 0) << r.err;
  }
  const nlohmann::json a = nlohmann::json::parse(read_file(dir_ / "b1" / "batch.json"));
  const nlohmann::json b = nlohmann::json::parse(read_file(dir_ / "b2" / "batch.json"));
  EXPECT_EQ(a["hashes"], b["hashes"]);
  EXPECT_EQ(a["bytes_per_sheet"], b["bytes_per_sheet"]);
  auto outcomes = [&](const char* dir) {  // CSV rows without the frame-time column
    std::istringstream in(read_file(dir_ / dir / "batch.csv"));
    std::string line, header;
    std::getline(in, header);
    std::vector<std::string> cells, rows;
    size_t time_column = 0;
    {
      std::istringstream h(header);
      std::string c;
      for (size_t i = 0; std::getline(h, c, ','); ++i)
        if (c.find("ms") != std::string::npos) time_column = i;
    }
    while (std::getline(in, line)) {
      std::istringstream l(line);
      std::string c, row;
      for (size_t i = 0; std::getline(l, c, ','); ++i)
        if (i != time_column) row += c + ",";
      rows.push_back(row);
    }
    return rows;
  };
  const std::vector<std::string> one = outcomes("b1"), two = outcomes("b2");
  ASSERT_EQ(one.size(), 4u);
  EXPECT_EQ(one, two);
}

// Textured OBJ (issue 5): a tearing run writes per frame OBJ + MTL, paper.png and the carved atlas; the
// MTL names the PNGs with map_Kd and map_d; rasterising the carved faces on the CPU (pattern position of
// each covered atlas pixel by barycentric interpolation) finds transparent pixels only near the detailed
// tear and opaque paper away from it.
TEST_F(Cli, TexturedObjShowsTheCarvedEdge) {
  const std::string scenario = std::string(PT_SOURCE_DIR) + "/scenarios/start-inward.json";
  const Result r = run({"run", scenario, "--out", "o", "--obj", "--frames", "40"});
  ASSERT_EQ(r.status, 0) << r.err;
  const fs::path frames = dir_ / "o" / "frames";
  const fs::path obj_path = frames / "frame_0040.obj", mtl_path = frames / "frame_0040.mtl";
  ASSERT_TRUE(fs::exists(obj_path));
  ASSERT_TRUE(fs::exists(mtl_path));
  ASSERT_TRUE(fs::exists(frames / "paper.png"));
  const std::string obj = read_file(obj_path), mtl = read_file(mtl_path);
  EXPECT_NE(obj.find("mtllib frame_0040.mtl\n"), std::string::npos);
  EXPECT_NE(mtl.find("map_Kd paper.png\n"), std::string::npos);
  EXPECT_NE(mtl.find("map_d paper.png\n"), std::string::npos);
  const size_t kd = mtl.find("map_Kd carved_");
  ASSERT_NE(kd, std::string::npos) << "no carved material after a tearing run:\n" << mtl;
  const std::string carved = mtl.substr(kd + 7, mtl.find('\n', kd) - kd - 7);
  EXPECT_NE(mtl.find("map_d " + carved + "\n"), std::string::npos) << mtl;
  ASSERT_TRUE(fs::exists(frames / carved)) << carved;
  // Fewer carved textures than frames: rewritten only when the carving changed.
  int32_t atlases = 0;
  for (const auto& e : fs::directory_iterator(frames)) atlases += e.path().filename().string().rfind("carved_", 0) == 0;
  EXPECT_GE(atlases, 1);
  EXPECT_LT(atlases, 40);

  // The tear's detailed path (pattern meters) and the texture frame (the outline's box, 0.1 mm pixels).
  const nlohmann::json res = nlohmann::json::parse(read_file(dir_ / "o" / "result.json"));
  std::vector<std::array<double, 2>> detail;
  for (const auto& t : res["tears"])
    for (const auto& q : t["detail"]) detail.push_back({q[0].get<double>(), q[1].get<double>()});
  ASSERT_GE(detail.size(), 10u) << "start-inward did not tear in 40 frames";
  int32_t pw = 0, ph = 0, aw = 0, ah = 0;
  std::vector<uint8_t> paper, atlas;
  pt::read_rgba_png((frames / "paper.png").string(), pw, ph, paper);
  pt::read_rgba_png((frames / carved).string(), aw, ah, atlas);
  // Texture pixel, m: the default of docs/architecture.md "Details"; the outline's box starts at 0.
  const double px = 1e-4;
  EXPECT_NEAR(pw * px, 0.148, 2 * px);
  EXPECT_NEAR(ph * px, 0.21, 2 * px);

  // Parse the OBJ: mesh vertex count, vt, carved faces.
  std::istringstream in(obj);
  std::string line, material;
  int32_t nv = -1;
  std::vector<std::array<double, 2>> vt;
  std::vector<std::array<std::array<int32_t, 2>, 3>> faces;
  while (std::getline(in, line)) {
    if (line.find(" mesh vertices ") != std::string::npos && line[0] == '#') nv = std::atoi(line.c_str() + 2);
    else if (line.rfind("vt ", 0) == 0) {
      double u = 0, v = 0;
      std::sscanf(line.c_str(), "vt %lf %lf", &u, &v);
      vt.push_back({u, v});
    } else if (line.rfind("usemtl ", 0) == 0) material = line.substr(7);
    else if (line.rfind("f ", 0) == 0 && material == "carved") {
      std::array<std::array<int32_t, 2>, 3> f{};
      ASSERT_EQ(std::sscanf(line.c_str(), "f %d/%d %d/%d %d/%d", &f[0][0], &f[0][1], &f[1][0], &f[1][1], &f[2][0],
                            &f[2][1]), 6) << line;
      faces.push_back(f);
    }
  }
  ASSERT_GT(nv, 0);
  ASSERT_FALSE(faces.empty());
  auto dist_to_tear = [&](double x, double y) {
    double best = 1e9;
    for (const auto& q : detail) best = std::min(best, std::hypot(q[0] - x, q[1] - y));
    return best;
  };
  // A lip's texture is transparent beyond the detailed path as far as its support strip reaches
  // (4σ + 2 px, docs/architecture.md "Details"), and opaque farther away.
  const double far = 4 * pt::DetailSettings{}.sigma + 2 * px + 1e-3;
  int64_t transparent = 0, opaque_far = 0, transparent_far = 0, covered = 0;
  double worst = 0;
  // Atlas patches are windows of the texture at the same pixel size: atlas pixel → pattern is a translation,
  // fixed by any corner that is a mesh vertex (its paper vt). Support-strip faces (two mesh corners, two
  // strip corners) are rasterised too: they carry the detail beyond the coarse edge.
  auto alpha_at = [&](const std::vector<uint8_t>& img, int w, int h, int x, int y) {
    return img[(static_cast<size_t>(std::clamp(y, 0, h - 1)) * w + std::clamp(x, 0, w - 1)) * 4 + 3];
  };
  for (const auto& f : faces) {
    int anchor = -1;
    for (int k = 0; k < 3 && anchor < 0; ++k)
      if (f[k][0] <= nv) anchor = k;
    ASSERT_GE(anchor, 0);
    std::array<std::array<double, 2>, 3> uv{};
    for (int k = 0; k < 3; ++k) uv[k] = {vt[f[k][1] - 1][0] * aw, (1.0 - vt[f[k][1] - 1][1]) * ah};  // atlas px, y down
    const auto& pv = vt[f[anchor][0] - 1];  // paper vt of the anchor vertex
    const double tx = pv[0] * pw * px - uv[anchor][0] * px, ty = pv[1] * ph * px + uv[anchor][1] * px;
    const double det = (uv[1][0] - uv[0][0]) * (uv[2][1] - uv[0][1]) - (uv[2][0] - uv[0][0]) * (uv[1][1] - uv[0][1]);
    if (std::abs(det) < 1e-9) continue;
    const int x0 = std::max(0, int(std::floor(std::min({uv[0][0], uv[1][0], uv[2][0]}))));
    const int x1 = std::min(aw - 1, int(std::ceil(std::max({uv[0][0], uv[1][0], uv[2][0]}))));
    const int y0 = std::max(0, int(std::floor(std::min({uv[0][1], uv[1][1], uv[2][1]}))));
    const int y1 = std::min(ah - 1, int(std::ceil(std::max({uv[0][1], uv[1][1], uv[2][1]}))));
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const double cx = x + 0.5, cy = y + 0.5;
        const double b1 = ((cx - uv[0][0]) * (uv[2][1] - uv[0][1]) - (uv[2][0] - uv[0][0]) * (cy - uv[0][1])) / det;
        const double b2 = ((uv[1][0] - uv[0][0]) * (cy - uv[0][1]) - (cx - uv[0][0]) * (uv[1][1] - uv[0][1])) / det;
        if (1 - b1 - b2 < 0 || b1 < 0 || b2 < 0) continue;  // pixel centre inside the face
        const double X = tx + cx * px, Y = ty - cy * px;
        // Outside the outline (paper.png transparent there too): not the carving's doing.
        if (alpha_at(paper, pw, ph, int(X / px), ph - 1 - int(Y / px)) == 0) continue;
        const double d = dist_to_tear(X, Y);
        const uint8_t a = atlas[(static_cast<size_t>(y) * aw + x) * 4 + 3];
        ++covered;
        if (a == 0) {
          ++transparent;
          worst = std::max(worst, d);
          transparent_far += d > far;
        } else if (d > far) {
          ++opaque_far;
        }
      }
  }
  EXPECT_GT(covered, 1000);
  EXPECT_GT(transparent, 200) << "too few pixels beyond the detailed path are transparent";
  EXPECT_EQ(transparent_far, 0) << "transparent pixels up to " << worst * 1e3 << " mm from the tear";
  EXPECT_GT(opaque_far, 1000) << "no opaque paper away from the tear";
  // And the untouched paper texture is opaque at the middle of the tear (carving lives in the atlas).
  const auto& mid = detail[detail.size() / 2];
  const int mx = int(mid[0] / px), my = ph - 1 - int(mid[1] / px);
  EXPECT_EQ(paper[(static_cast<size_t>(my) * pw + mx) * 4 + 3], 255);
}

}  // namespace

// ---- issue 27: the adversarial probe ----

// ---- issue 27: the adversarial probe ----

// ---- issue 27: the adversarial probe ----

// ---- issue 27: the adversarial probe ----

// Constants no sheet could have: exit 2 naming the key, nothing written (before: exit 0, status "ok", every
// substep refused; or exit 1 with a non-finite state).
TEST_F(Cli, ImplausibleConstantsAreExit2) {
  const fs::path g = good();
  for (const std::string setting : {"material.young=1e308", "material.thickness=1e308", "sim.fps=1e-300",
                                    "material.bending_scale=1e300", "material.density=1e300"}) {
    const Result r = run({"run", g.string(), "--set", setting, "--out", "o"});
    expect_input_error(r, setting);
    EXPECT_NE(r.err.find(setting.substr(0, setting.find('=')) + ": outside the plausible range"), std::string::npos)
        << r.err;
    EXPECT_FALSE(fs::exists(dir_ / "o")) << setting;
    expect_input_error(run({"check", g.string(), "--set", setting}), "check " + setting);
  }
}

// Issue 27, item 8: --obj wrote 52 kB a frame until the disk was full. A run whose estimated frames do not
// fit the free space is refused before it starts: exit 2 naming --obj and the estimate, nothing written.
TEST_F(Cli, ObjThatCannotFitOnTheDiskIsRefused) {
  if (static_cast<double>(fs::space(dir_).available) > 1e13) GTEST_SKIP() << "more than 10 TB free here";
  // 20 000 triangles: about 1.6 MB a frame, 16 TB for 10 million frames.
  const Result r = run({"run", good().string(), "--out", "o", "--obj", "--frames", "10000000", "--set",
                        "sheet.triangles=20000", "--set", "sim.gravity=[0, 0, 0]"});
  expect_input_error(r, "--obj beyond the free space");
  EXPECT_EQ(r.err.rfind("papertear: --obj: 10000000 textured frames of ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find(" TB on disk, but "), std::string::npos) << r.err;  // 16 TB
  EXPECT_TRUE(r.out.empty()) << r.out;
  EXPECT_FALSE(fs::exists(dir_ / "o"));
}

// Issue 27, item 8: SIGINT or SIGTERM during an --obj run removes its hidden partial frames and the output
// directory it created, keeps a directory that was there, and the process still ends by the signal
// (before: .frames.partial.PID and the new directory stayed).
TEST_F(Cli, InterruptedObjRunLeavesNothingBehind) {
  const fs::path g = good();
  fs::create_directories(dir_ / "kept");
  write_file(dir_ / "kept" / "mine.txt", "mine");
  for (const auto& [sig, out] : {std::pair<int, std::string>{SIGINT, "o"}, std::pair<int, std::string>{SIGTERM, "kept"}}) {
    const fs::path err_path = dir_ / "stderr.txt";
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      const int err = ::open(err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      const int null = ::open("/dev/null", O_WRONLY);
      if (err < 0 || null < 0 || ::dup2(err, 2) < 0 || ::dup2(null, 1) < 0 || ::chdir(dir_.c_str()) != 0) ::_exit(127);
      ::execl(kBinary.c_str(), kBinary.c_str(), "run", g.c_str(), "--out", out.c_str(), "--obj", "--frames", "10000",
              "--threads", "1", static_cast<char*>(nullptr));
      ::_exit(127);
    }
    const fs::path partial = dir_ / out / (".frames.partial." + std::to_string(pid));
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (!fs::exists(partial / "frame_0002.obj") && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    EXPECT_TRUE(fs::exists(partial / "frame_0002.obj")) << "no frame written within 60 s";
    ::kill(pid, sig);
    int status = 0;
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == sig) << "status " << status;
    const std::string err = read_file(err_path);
    EXPECT_TRUE(one_line(err)) << err;
    EXPECT_NE(err.find(sig == SIGINT ? ": SIGINT at frame " : ": SIGTERM at frame "), std::string::npos) << err;
    EXPECT_FALSE(fs::exists(partial)) << partial;
    fs::remove(err_path);
  }
  EXPECT_FALSE(fs::exists(dir_ / "o"));
  EXPECT_EQ(listing(), (std::vector<std::string>{"good.json", "kept", "kept/mine.txt"}));
}

// Issue 27, item 8: a run killed outright cannot clean up; the next --obj run into the directory removes
// the hidden frames of processes that no longer exist (and not those of a live one).
TEST_F(Cli, ObjRunRemovesTheHiddenFramesOfADeadRun) {
  const fs::path dead = dir_ / "o" / ".frames.partial.999999999", live = dir_ / "o" / ".frames.partial.1";
  fs::create_directories(dead);
  fs::create_directories(live);
  write_file(dead / "frame_0001.obj", "a killed run's");
  const Result r = run({"run", good().string(), "--out", "o", "--obj", "--frames", "1", "--threads", "1"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_FALSE(fs::exists(dead));
  EXPECT_TRUE(fs::exists(live));
}

// Issue 27, item 5: an outline far thinner than the mesh size (0.3 m x 1e-7 m at 200 triangles) passed
// check, then meshed 4.19 M triangles and took 14 GB; now check and run refuse it: exit 2, one line
// naming the file and sheet.outline.
TEST_F(Cli, OutlineFarThinnerThanTheMeshIsExit2) {
  std::string text = kGood;
  text.replace(text.find(R"("preset": "A6")"), 14, R"("outline": [[0, 0], [0.3, 0], [0.3, 1e-7], [0, 1e-7]])");
  text.replace(text.find("[0.02, 0.14]"), 12, "[0.1, 5e-8]");
  text.replace(text.find("[0.085, 0.14]"), 13, "[0.2, 5e-8]");
  write_file(dir_ / "thin.json", text);
  for (const std::vector<std::string>& args : {std::vector<std::string>{"check", "thin.json"},
                                                std::vector<std::string>{"run", "thin.json", "--out", "o"}}) {
    const Result r = run(args);
    expect_input_error(r, "thin outline, " + args[0]);
    EXPECT_NE(r.err.find("thin.json: sheet.outline: features far finer than a mesh of 60 triangles"),
              std::string::npos)
        << r.err;
  }
  EXPECT_FALSE(fs::exists(dir_ / "o"));
}

// Issue 27, item 6: a batch runs --threads sheets at once; sheets at the triangle cap that would not fit
// the machine's memory together are refused before any runs: exit 2 naming --threads and the estimate.
// --threads is capped at the CPUs, so the sheets at once are the CPUs at most: the address space is limited
// instead (ulimit -v 3 GB), below what one sheet of 500 000 triangles takes (about 4.3 GB).
TEST_F(Cli, BatchBeyondTheMachinesMemoryIsExit2) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer reserves terabytes of shadow address space: no ulimit -v lets it start";
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
  GTEST_SKIP() << "AddressSanitizer reserves terabytes of shadow address space: no ulimit -v lets it start";
#endif
#endif
  const Result r = run_program(kBinary, {"batch", good().string(), "--sheets", "2", "--threads", "2", "--set",
                                         "sheet.triangles=500000", "--out", "b"},
                               "ulimit -v 3000000 &&");
  expect_input_error(r, "batch beyond memory");
  const int32_t at_once = std::min(2, static_cast<int32_t>(tbb::info::default_concurrency()));
  EXPECT_EQ(r.err.rfind("papertear: --threads: " + std::to_string(at_once) + " sheet", 0), 0u) << r.err;
  EXPECT_NE(r.err.find("the process may use (ulimit -v)"), std::string::npos) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
  EXPECT_FALSE(fs::exists(dir_ / "b"));
}

// check and run agree on a finger just outside the outline, and both name its JSON path (before: check
// exit 0, run exit 2 "point (-1e-10, 0.14) is outside the outline").
TEST_F(Cli, CheckAndRunAgreeOnAFingerJustOutside) {
  std::string text = kGood;
  text.replace(text.find("[0.02, 0.14]"), 12, "[-1e-10, 0.14]");
  write_file(dir_ / "edge.json", text);
  for (const char* command : {"check", "run"}) {
    const Result r = run({command, "edge.json"});
    expect_input_error(r, command);
    EXPECT_NE(r.err.find("edge.json: fingers[0].at: finger A at (-1e-10, 0.14) is outside the sheet"),
              std::string::npos)
        << command << ": " << r.err;
  }
  EXPECT_FALSE(fs::exists(dir_ / "out"));
}

// An output location that cannot be a directory: exit 2, one line naming --out, before any sheet runs
// (before: exit 1 "internal error: cannot create ...", batch only after running every sheet).
TEST_F(Cli, UnusableOutIsExit2BeforeRunning) {
  const fs::path g = good();
  write_file(dir_ / "taken", "x");
  for (const std::string out : {"/proc/x", "taken/sub", "taken/sub/deeper"}) {
    for (const std::vector<std::string>& args :
         {std::vector<std::string>{"run", g.string(), "--out", out},
          std::vector<std::string>{"batch", g.string(), "--sheets", "2", "--out", out}}) {
      const Result r = run(args);
      expect_input_error(r, args[0] + " --out " + out);
      EXPECT_NE(r.err.find("--out " + out + ": "), std::string::npos) << r.err;
      EXPECT_TRUE(r.out.empty()) << "ran before refusing the output: " << r.out;
    }
  }
  EXPECT_EQ(read_file(dir_ / "taken"), "x");
  EXPECT_FALSE(fs::exists(dir_ / "out"));
}

// An empty name or --out "" is refused, not turned into out/ or the default (before: exit 0, out/result.json;
// --out "" wrote out/cli-good).
TEST_F(Cli, EmptyNameAndEmptyOutAreExit2) {
  std::string text = kGood;
  text.replace(text.find("\"cli-good\""), 10, "\"\"");
  write_file(dir_ / "noname.json", text);
  const Result r = run({"run", "noname.json"});
  expect_input_error(r, "empty name");
  EXPECT_NE(r.err.find("noname.json: name: must not be empty"), std::string::npos) << r.err;
  expect_input_error(run({"check", "noname.json"}), "check empty name");
  EXPECT_FALSE(fs::exists(dir_ / "out"));
  for (const char* command : {"run", "batch"}) {
    std::vector<std::string> args{command, good().string(), "--out", ""};
    if (std::string(command) == "batch") args.insert(args.end(), {"--sheets", "2"});
    const Result e = run(args);
    expect_input_error(e, std::string(command) + " --out \"\"");
    EXPECT_NE(e.err.find("--out: "), std::string::npos) << e.err;
  }
  EXPECT_FALSE(fs::exists(dir_ / "out"));
}

// --set values out of a number's range or not UTF-8: exit 2 naming the --set option (before: "got a string";
// exit 1 "internal error: [json.exception.type_error.316] ...").
TEST_F(Cli, SetOutOfRangeOrNotUtf8IsExit2) {
  const fs::path g = good();
  const Result big = run({"check", g.string(), "--set", "material.young=1e400"});
  expect_input_error(big, "1e400");
  EXPECT_NE(big.err.find("--set material.young=1e400: 1e400 is out of the range of a number"), std::string::npos)
      << big.err;
  const Result utf = run({"run", g.string(), "--set", "name=\xff", "--out", "u"});
  expect_input_error(utf, "invalid UTF-8");
  EXPECT_NE(utf.err.find("--set name=\\xff: not UTF-8 text"), std::string::npos) << utf.err;
  EXPECT_EQ(utf.err.find("internal"), std::string::npos) << utf.err;
  EXPECT_FALSE(fs::exists(dir_ / "u"));
}

// ---- issue 27, item 20: a failure is one line on stderr, a success prints nothing there ----

// libpng printed its own "libpng error: Write Error" before papertear's line; /dev/full fails every write
// with ENOSPC, as a full disk does.
TEST_F(Cli, PngWriteOnAFullDiskIsOneLine) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full";
  fs::create_directories(dir_ / "o");
  fs::create_symlink("/dev/full", dir_ / "o" / "pattern.png");
  const Result r = run({"run", good().string(), "--out", "o", "--png", "--frames", "1"});
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_TRUE(one_line(r.err)) << "stderr is not exactly one line:\n" << r.err;
  EXPECT_EQ(r.err.rfind("papertear: ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find("o/pattern.png: PNG write failed: Write Error (No space left on device)"), std::string::npos)
      << r.err;
}

// TBB printed "TBB Warning: The number of workers is currently limited to ..." for --threads beyond the
// CPUs, and the summary said "1000 threads" while it ran on what TBB gave.
TEST_F(Cli, ThreadsBeyondTheCpusAreCappedAndTheSummarySaysSo) {
  const int cpus = std::max(1, static_cast<int>(tbb::info::default_concurrency()));
  if (cpus >= 1000) GTEST_SKIP() << cpus << " CPUs";
  const std::string used = std::to_string(cpus) + (cpus == 1 ? " thread" : " threads");
  const std::string note = "--threads 1000 capped at the " + std::to_string(cpus) + (cpus == 1 ? " CPU" : " CPUs") +
                           " available";
  const Result r = run({"run", good().string(), "--out", "o", "--threads", "1000"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.err, "");
  EXPECT_NE(r.out.find("(" + used + "; " + note + ")\n"), std::string::npos) << r.out;
  EXPECT_EQ(nlohmann::json::parse(read_file(dir_ / "o" / "result.json"))["threads"], cpus);
  const Result b = run({"batch", good().string(), "--sheets", "2", "--out", "b", "--threads", "1000"});
  ASSERT_EQ(b.status, 0) << b.err;
  EXPECT_EQ(b.err, "");
  EXPECT_NE(b.out.find(" on " + used + " (" + note + ") in "), std::string::npos) << b.out;
  // At or under the CPUs nothing is said.
  const Result one = run({"run", good().string(), "--out", "o1", "--threads", "1"});
  EXPECT_NE(one.out.find("(1 thread)\n"), std::string::npos) << one.out;
}

// The viewer printed its usage after the line saying what was wrong, and GLFW's reason on a line of its own
// before "cannot initialise GLFW".
TEST_F(Cli, ViewerFailuresAreOneLine) {
  if (!fs::exists(kViewer)) GTEST_SKIP() << kViewer << " not built";
  const Result option = run_program(kViewer, {"--bogus"});
  EXPECT_EQ(option.status, 2);
  EXPECT_EQ(option.err, "papertear-viewer: unknown option --bogus (--help for the usage)\n");
  const Result value = run_program(kViewer, {"--threads", "0"});
  EXPECT_EQ(value.status, 2);
  EXPECT_TRUE(one_line(value.err)) << value.err;
  EXPECT_NE(value.err.find("--threads: expected an integer"), std::string::npos) << value.err;
  const Result display = run_program(kViewer, {good().string(), "--frames", "1"}, "env -u DISPLAY -u WAYLAND_DISPLAY");
  EXPECT_EQ(display.status, 1) << display.err;
  EXPECT_TRUE(one_line(display.err)) << "stderr is not exactly one line:\n" << display.err;
  EXPECT_EQ(display.err.rfind("papertear-viewer: cannot initialise GLFW", 0), 0u) << display.err;
  const Result help = run_program(kViewer, {"--help"});
  EXPECT_EQ(help.status, 0);
  EXPECT_EQ(help.err, "");
  EXPECT_EQ(help.out.rfind("usage: papertear-viewer", 0), 0u) << help.out;
}
