#include "engine/batch.hpp"

#include "components/capacity_bytes.hpp"
#include "engine/result_writer.hpp"

#include <nlohmann/json.hpp>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/task_arena.h>
#include <sys/resource.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace pt {

const std::vector<std::string>& variation_keys() {
  static const std::vector<std::string> keys = {
      "material.thickness",     "material.density",           "material.young",
      "material.poisson",       "material.bending_scale",     "material.tip_damage",
      "material.fracture_c",    "material.speed",             "material.max_step",
      "material.damping",       "material.fiber_scale",       "material.membrane_scale",
      "material.strain_limit",  "material.compression_scale", "material.compression_limit",
      "detail.sigma",           "detail.omega",               "sim.substeps",
      "sim.iterations",         "sim.relaxation_radius",      "tearing.radius",
      "tearing.snap",           "tearing.shielding_radius",   "tearing.max_turn_deg",
      "tearing.start_wrap",     "tearing.start_length",       "tearing.edge_radius",
      "tearing.bearing_length", "tearing.opening_floor",    "finger_speed"};
  return keys;
}

Variation parse_variation(const std::string& text) {
  const auto eq = text.find('=');
  const auto colon = text.find(':', eq == std::string::npos ? 0 : eq);
  if (eq == std::string::npos || colon == std::string::npos)
    throw InputError("--vary " + text + ": expected KEY=FROM:TO");
  Variation v;
  v.key = text.substr(0, eq);
  bool ok = false;
  for (const std::string& k : variation_keys()) ok = ok || v.key == k;
  if (!ok) throw InputError("--vary " + text + ": unknown key '" + v.key + "'");
  try {
    size_t used = 0;
    const std::string a = text.substr(eq + 1, colon - eq - 1), b = text.substr(colon + 1);
    v.from = std::stod(a, &used);
    if (used != a.size()) throw std::invalid_argument(a);
    v.to = std::stod(b, &used);
    if (used != b.size()) throw std::invalid_argument(b);
  } catch (const std::exception&) {
    throw InputError("--vary " + text + ": FROM and TO must be numbers");
  }
  if (!std::isfinite(v.from) || !std::isfinite(v.to)) throw InputError("--vary " + text + ": not finite");
  return v;
}

namespace {
void apply_variation(const std::string& key, double value, Scenario& s) {
  Material& m = s.material;
  if (key == "material.thickness") m.thickness = value;
  else if (key == "material.density") m.density = value;
  else if (key == "material.young") m.young = value;
  else if (key == "material.poisson") m.poisson = value;
  else if (key == "material.bending_scale") m.bending_scale = value;
  else if (key == "material.tip_damage") m.tip_damage = value;
  else if (key == "material.fracture_c") m.fracture_c = value;
  else if (key == "material.speed") m.speed = value;
  else if (key == "material.max_step") m.max_step = value;
  else if (key == "material.damping") m.damping = value;
  else if (key == "material.fiber_scale") m.fiber_scale = value;
  else if (key == "material.membrane_scale") m.membrane_scale = value;
  else if (key == "material.strain_limit") m.strain_limit = value;
  else if (key == "material.compression_scale") m.compression_scale = value;
  else if (key == "material.compression_limit") m.compression_limit = value;
  else if (key == "detail.sigma") s.detail.sigma = value;
  else if (key == "detail.omega") s.detail.omega = value;
  else if (key == "sim.substeps") s.sim.substeps = std::max(1, static_cast<int32_t>(std::lround(value)));
  else if (key == "sim.iterations") s.sim.iterations = std::max(1, static_cast<int32_t>(std::lround(value)));
  else if (key == "sim.relaxation_radius") s.sim.relaxation_radius = value;
  else if (key == "tearing.radius") s.tearing.radius = value;
  else if (key == "tearing.snap") s.tearing.snap = value;
  else if (key == "tearing.shielding_radius") s.tearing.shielding_radius = value;
  else if (key == "tearing.max_turn_deg") s.tearing.max_turn_deg = value;
  else if (key == "tearing.start_wrap") s.tearing.start_wrap = value;
  else if (key == "tearing.start_length") s.tearing.start_length = value;
  else if (key == "tearing.edge_radius") s.tearing.edge_radius = value;
  else if (key == "tearing.bearing_length") s.tearing.bearing_length = value;
  else if (key == "tearing.opening_floor") s.tearing.opening_floor = value;
  else if (key == "finger_speed") {
    // Motions play `value` times faster: every key time is divided by it.
    const double scale = value > 0 ? value : 1.0;
    for (FingerSpec& f : s.fingers)
      for (FingerKey& k : f.keys) k.t /= scale;
    for (HandSpec& h : s.hands)
      for (HandKey& k : h.keys) k.t /= scale;
  }
}

}  // namespace

size_t sheet_bytes(const Sheet& s) {
  size_t b = sizeof(Sheet);
  b += capacity_bytes(s.verts.x) + capacity_bytes(s.verts.v) + capacity_bytes(s.verts.force) +
       capacity_bytes(s.verts.rest) + capacity_bytes(s.verts.mass) + capacity_bytes(s.verts.flags) +
       capacity_bytes(s.verts.tear);
  b += capacity_bytes(s.tris.tri) + capacity_bytes(s.tris.rest_inv) + capacity_bytes(s.tris.rest_area) +
       capacity_bytes(s.tris.corner_force) + capacity_bytes(s.tris.region) + capacity_bytes(s.tris.piece) +
       capacity_bytes(s.tris.side);
  b += capacity_bytes(s.topo.fans) + capacity_bytes(s.topo.vt_tri) + capacity_bytes(s.topo.neighbor) +
       capacity_bytes(s.topo.edge_hinge) + capacity_bytes(s.topo.hinges) + capacity_bytes(s.topo.boundary_next) + capacity_bytes(s.topo.boundary_prev) +
       capacity_bytes(s.topo.boundary_vertices);
  b += capacity_bytes(s.regions) + capacity_bytes(s.tips) + capacity_bytes(s.tears) + capacity_bytes(s.fingers) +
       capacity_bytes(s.hands);
  for (const Tear& t : s.tears) b += capacity_bytes(t.tips) + capacity_bytes(t.detail);
  for (const Finger& f : s.fingers) b += capacity_bytes(f.keys) + f.name.capacity();
  return b;
}

Scenario batch_sheet_scenario(const Scenario& base, const BatchOptions& options, int32_t index) {
  Scenario s = base;
  // Sheet 0 is the scenario itself; the others get their own fibres and mesh (splitmix-style spread).
  if (index > 0 && !options.fixed_seeds) {
    uint64_t z = base.material.fiber_seed + 0x9E3779B97F4A7C15ull * static_cast<uint64_t>(index);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    s.material.fiber_seed = (z ^ (z >> 31)) | 1u;
    s.mesh_seed = base.mesh_seed + static_cast<uint64_t>(index);
  }
  if (options.frames >= 0) s.sim.frames = options.frames;
  for (const Variation& v : options.vary) {
    const double a = options.sheets > 1 ? static_cast<double>(index) / (options.sheets - 1) : 0.0;
    apply_variation(v.key, v.from + (v.to - v.from) * a, s);
  }
  return s;
}

void validate_batch_sheet(const Scenario& base, const BatchOptions& options, int32_t index) {
  try {
    validate_scenario(batch_sheet_scenario(base, options, index));
  } catch (const InputError& e) {
    throw InputError(std::string(e.what()) + " (batch sheet " + std::to_string(index) + ")");
  }
}

SheetRun run_batch_sheet(const Scenario& base, const BatchOptions& options, int32_t index) {
  SheetRun run;
  SheetOutcome& out = run.outcome;
  out.index = index;
  const Scenario s = batch_sheet_scenario(base, options, index);
  out.fiber_seed = s.material.fiber_seed;
  out.mesh_seed = s.mesh_seed;
  for (const Variation& v : options.vary) {
    const double a = options.sheets > 1 ? static_cast<double>(index) / (options.sheets - 1) : 0.0;
    out.varied.push_back(v.from + (v.to - v.from) * a);
  }
  try {
    EngineOptions eo;
    eo.threads = std::max(1, options.threads_per_sheet);
    Simulation sim(s, eo);
    for (int32_t f = 0; f < s.sim.frames; ++f) sim.step();
    sim.flush();
    const Sheet& sh = sim.sheet();
    out.triangles = sh.tris.size();
    out.tears = static_cast<int32_t>(sh.tears.size());
    out.pieces = sh.topo.piece_count;
    for (const Tear& t : sh.tears)
      for (size_t k = 1; k < t.tips.size(); ++k) out.tear_length += (t.tips[k] - t.tips[k - 1]).norm();
    for (const Finger& f : sh.fingers) out.max_finger_force = std::max(out.max_finger_force, f.max_force);
    out.frame_ms = sim.timings().frame.avg();
    out.hash = sim.state_hash();
    run.systems = sim.timings().systems;
    run.frames_timed = sim.timings().frame.count;
    run.bytes = sheet_bytes(sh);
    run.solver_bytes = sim.solver_bytes();
    for (const FrameStats& fs : sim.frame_stats()) run.triangles += fs.triangles;
    if (const std::string why = solver_failure(sim); !why.empty()) out.status = "error: " + why;
  } catch (const std::exception& e) {
    out.status = std::string("error: ") + e.what();
  }
  return run;
}

BatchResult merge_batch_sheets(const Scenario& base, const BatchOptions& options, const std::vector<SheetRun>& runs,
                               double wall_s) {
  BatchResult result;
  result.sheets = options.sheets;
  result.threads = options.threads;
  result.frames = options.frames >= 0 ? options.frames : base.sim.frames;
  result.vary = options.vary;
  result.fixed_seeds = options.fixed_seeds;
  result.wall_s = wall_s;
  // Per-sheet reports in sheet order (deterministic sums).
  size_t total_bytes = 0, total_solver_bytes = 0;
  int64_t sheet_frames = 0;
  for (const SheetRun& run : runs) {
    for (size_t k = 0; k < kSystems.size(); ++k) {
      const TimingStat& s = run.systems[k];
      result.systems[k].sum += s.sum;
      result.systems[k].count += s.count;
      result.systems[k].max = std::max(result.systems[k].max, s.max);
      result.throughput[k].calls += s.count;
      result.throughput[k].total_ms += s.sum;
      result.throughput[k].triangles += run.triangles;
    }
    sheet_frames += run.frames_timed;
    total_bytes += run.bytes;
    total_solver_bytes += run.solver_bytes;
    result.outcomes.push_back(run.outcome);
  }
  result.bytes_per_sheet = options.sheets ? total_bytes / options.sheets : 0;
  result.solver_bytes_per_sheet = options.sheets ? total_solver_bytes / options.sheets : 0;
  result.sheet_frames_per_s = wall_s > 0 ? static_cast<double>(sheet_frames) / wall_s : 0.0;
  return result;
}

void check_batch_threads(const BatchOptions& options) {
  if (options.threads < 1 || options.threads > kMaxThreads || options.threads_per_sheet > kMaxThreads)
    throw InputError("batch threads: must be 1 to " + std::to_string(kMaxThreads) + ", got " +
                     std::to_string(std::max(options.threads, options.threads_per_sheet)));
}

namespace {
std::string plural(int64_t n, const char* word) { return std::to_string(n) + " " + word + (n == 1 ? "" : "s"); }

std::string gigabytes(double bytes) {
  char buf[32];
  if (bytes >= 1e12) std::snprintf(buf, sizeof buf, "%.1f TB", bytes / 1e12);
  else std::snprintf(buf, sizeof buf, "%.3g GB", bytes / 1e9);
  return buf;
}
}  // namespace

void check_batch_memory(int32_t at_once, int32_t triangles, const std::string& option) {
  double usable = static_cast<double>(::sysconf(_SC_PHYS_PAGES)) * static_cast<double>(::sysconf(_SC_PAGE_SIZE));
  const char* what = "the machine has ";
  rlimit limit{};
  if (::getrlimit(RLIMIT_AS, &limit) == 0 && limit.rlim_cur != RLIM_INFINITY &&
      static_cast<double>(limit.rlim_cur) < usable) {
    usable = static_cast<double>(limit.rlim_cur);
    what = "the process may use (ulimit -v) ";
  }
  const double need = at_once * estimated_sheet_bytes(static_cast<int64_t>(triangles) * 6 / 5);
  if (!(usable > 0) || need <= usable) return;
  throw InputError(option + ": " + plural(at_once, "sheet") + " of " + plural(triangles, "triangle") +
                   " at once would take about " + gigabytes(need) + " of memory, " + what + gigabytes(usable) +
                   " (fewer " + option + " or triangles)");
}

BatchResult run_batch(const Scenario& base, const BatchOptions& options,
                      const std::function<void(int32_t, int32_t)>& progress) {
  check_batch_threads(options);
  std::vector<SheetRun> runs(options.sheets);
  std::atomic<int32_t> done{0};
  const auto t0 = std::chrono::steady_clock::now();
  tbb::task_arena arena(std::max(1, options.threads));
  arena.execute([&] {
    // One sheet per task: sheets differ in cost (tears, remeshing) and work stealing evens them out. Each
    // task writes only its own runs[i]; the sums are made afterwards (adding into shared totals from the
    // tasks raced between workers, TSan, issue 9).
    tbb::parallel_for(0, options.sheets, [&](int32_t i) {
      runs[i] = run_batch_sheet(base, options, i);
      const int32_t n = ++done;
      if (progress) progress(n, options.sheets);
    });
  });
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return merge_batch_sheets(base, options, runs, wall_s);
}

void write_batch_json(const BatchResult& r, const std::string& scenario_name, const std::string& path) {
  nlohmann::ordered_json j;
  j["scenario"] = scenario_name;
  j["sheets"] = r.sheets;
  j["threads"] = r.threads;
  // Only from several ranks: one process writes the batch.json it always wrote.
  if (r.ranks > 1) j["ranks"] = r.ranks;
  j["frames"] = r.frames;
  nlohmann::ordered_json vary = nlohmann::json::array();
  for (const Variation& v : r.vary) vary.push_back({{"key", v.key}, {"from", v.from}, {"to", v.to}});
  j["vary"] = vary;
  j["fixed_seeds"] = r.fixed_seeds;
  j["wall_s"] = r.wall_s;
  j["sheet_frames_per_s"] = r.sheet_frames_per_s;
  nlohmann::ordered_json timings, throughput;
  for (size_t k = 0; k < kSystems.size(); ++k) {
    timings[kSystems[k].name] = r.systems[k].avg();
    const SystemThroughput& t = r.throughput[k];
    throughput[kSystems[k].name] = {{"calls", t.calls},
                                   {"time_ms", t.total_ms},
                                   {"triangles_per_s", t.total_ms > 0 ? t.triangles / (t.total_ms / 1000.0) : 0.0}};
  }
  j["timings_ms"] = timings;
  j["throughput"] = throughput;
  j["bytes_per_sheet"] = r.bytes_per_sheet;
  j["solver_bytes_per_sheet"] = r.solver_bytes_per_sheet;  // the implicit solver's structure and factor
  nlohmann::ordered_json hashes = nlohmann::json::array(), outcomes = nlohmann::json::array();
  for (const SheetOutcome& o : r.outcomes) {
    hashes.push_back(o.hash);
    nlohmann::ordered_json values = nlohmann::json::object();  // the varied keys' values for this sheet
    for (size_t k = 0; k < r.vary.size() && k < o.varied.size(); ++k) values[r.vary[k].key] = o.varied[k];
    outcomes.push_back({{"index", o.index},
                        {"fiber_seed", o.fiber_seed},
                        {"mesh_seed", o.mesh_seed},
                        {"varied", o.varied},
                        {"values", values},
                        {"triangles", o.triangles},
                        {"tear_length", o.tear_length},
                        {"tears", o.tears},
                        {"pieces", o.pieces},
                        {"max_finger_force", o.max_finger_force},
                        {"frame_ms", o.frame_ms},
                        {"status", o.status}});
  }
  j["hashes"] = hashes;
  j["outcomes"] = outcomes;
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp);
    f << j.dump(2) << "\n";
    if (!f) throw std::runtime_error("cannot write " + path);
  }
  std::filesystem::rename(tmp, path);
}

void write_batch_csv(const BatchResult& r, const std::string& path) {
  std::ofstream f(path);
  // One column per varied key, named by it, after the fixed columns.
  f << "index,fiber_seed,mesh_seed,triangles,tear_length_m,tears,pieces,max_finger_force_n,frame_ms,hash,status";
  for (const Variation& v : r.vary) f << "," << v.key;
  f << "\n";
  for (const SheetOutcome& o : r.outcomes) {
    char line[512];
    std::snprintf(line, sizeof line, "%d,%llu,%llu,%d,%.9g,%d,%d,%.9g,%.6g,%s,\"%s\"", o.index,
                  static_cast<unsigned long long>(o.fiber_seed), static_cast<unsigned long long>(o.mesh_seed),
                  o.triangles, o.tear_length, o.tears, o.pieces, o.max_finger_force, o.frame_ms, o.hash.c_str(),
                  o.status.c_str());
    f << line;
    for (const double value : o.varied) {
      char cell[40];
      std::snprintf(cell, sizeof cell, ",%.9g", value);
      f << cell;
    }
    f << "\n";
  }
}

}  // namespace pt
