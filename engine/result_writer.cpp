// result.json, pattern SVG and per-frame OBJ (docs/result-format.md). Output is deterministic: fixed key
// order (ordered_json), fixed number formats, no timestamps — except the timings themselves.
#include "engine/result_writer.hpp"

#include "engine/simulation.hpp"
#include "engine/simulation_internals.hpp"
#include "engine/texture_export.hpp"
#include "systems/carving/carving.hpp"

#include <nlohmann/json.hpp>

#include <unistd.h>

#include <algorithm>
#include <climits>
#include <cerrno>
#include <charconv>
#include <cstdarg>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <stdexcept>
#include <utility>

namespace pt {
namespace {

using ojson = nlohmann::ordered_json;

// Numbers go through here so a NaN or inf never reaches a file: it becomes null and the status "error".
struct Numbers {
  bool finite = true;
  ojson operator()(double v) {
    if (std::isfinite(v)) return v;
    finite = false;
    return nullptr;
  }
  ojson uv(const Vec2& p) { return ojson::array({(*this)(p.x()), (*this)(p.y())}); }
  ojson path(const std::vector<Vec2>& points) {
    ojson a = ojson::array();
    for (const Vec2& p : points) a.push_back(uv(p));
    return a;
  }
  ojson stat(const TimingStat& s) { return ojson{{"avg", (*this)(s.avg())}, {"max", (*this)(s.max)}}; }
};

const char* start_kind_name(StartKind k) {
  switch (k) {
    case StartKind::Finger: return "finger";
    case StartKind::Junction: return "junction";
    case StartKind::Inward: return "inward";
  }
  return "inward";
}

// Pictures and meshes are not results (result.json reports the error), but must not contain "nan" either.
double finite_or_zero(double v) { return std::isfinite(v) ? v : 0.0; }

struct Box {
  Vec2 lo = Vec2::Constant(std::numeric_limits<double>::infinity());
  Vec2 hi = -Vec2::Constant(std::numeric_limits<double>::infinity());
  void add(const Vec2& p) {
    if (!p.allFinite()) return;
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  bool valid() const { return lo.x() <= hi.x() && lo.y() <= hi.y(); }
};

// The texture spans the outline's bounding box (docs/architecture.md "Details"); pattern points stay
// inside it.
Box pattern_box(const Simulation& sim) {
  Box b;
  for (const Vec2& p : sim.scenario().outline) b.add(p);
  for (const Vec2& p : sim.sheet().verts.rest) b.add(p);
  if (!b.valid()) b.lo = b.hi = Vec2::Zero();
  return b;
}

void appendf(std::string& out, const char* format, ...) __attribute__((format(printf, 2, 3)));
void appendf(std::string& out, const char* format, ...) {
  char buf[256];
  va_list args;
  va_start(args, format);
  const int n = std::vsnprintf(buf, sizeof buf, format, args);
  va_end(args);
  if (n > 0) out.append(buf, std::min<size_t>(static_cast<size_t>(n), sizeof buf - 1));
}

std::string xml_escape(const std::string& s) {
  std::string out;
  for (const char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += (static_cast<unsigned char>(c) < 0x20) ? '?' : c;
    }
  }
  return out;
}

// Undirected edges used by one triangle only, in the triangles' (counter-clockwise) direction.
std::vector<std::pair<int32_t, int32_t>> boundary_edges(const std::vector<Tri>& tris) {
  std::vector<std::pair<uint64_t, std::pair<int32_t, int32_t>>> edges;
  edges.reserve(tris.size() * 3);
  for (const Tri& t : tris)
    for (int i = 0; i < 3; ++i) {
      const int32_t a = t[i], b = t[(i + 1) % 3];
      const uint64_t key = (uint64_t(uint32_t(std::min(a, b))) << 32) | uint32_t(std::max(a, b));
      edges.push_back({key, {a, b}});
    }
  std::sort(edges.begin(), edges.end());
  std::vector<std::pair<int32_t, int32_t>> out;
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    while (j < edges.size() && edges[j].first == edges[i].first) ++j;
    if (j - i == 1) out.push_back(edges[i].second);
    i = j;
  }
  return out;
}

// JSON text for people and diff tools: objects one key per line, arrays of scalars (points, short
// lists) on one line, doubles in their shortest round-trip form (0.111, not 0.11099999999999999).
void append_number(const ojson& j, std::string& out) {
  if (!j.is_number_float()) {
    out += j.dump();
    return;
  }
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, j.get<double>());
  out.append(buf, r.ptr);
}

bool is_scalar(const ojson& j) { return !j.is_array() && !j.is_object(); }

void append_pretty(const ojson& j, int indent, std::string& out) {
  if (j.is_number()) return append_number(j, out);
  if (is_scalar(j)) {
    out += j.dump();
    return;
  }
  if (j.empty()) {
    out += j.is_array() ? "[]" : "{}";
    return;
  }
  const bool all_scalar = std::all_of(j.begin(), j.end(), [](const ojson& e) { return is_scalar(e); });
  if (all_scalar && (j.is_array() || j.size() <= 4)) {
    out += j.is_array() ? "[" : "{";
    bool first = true;
    for (auto it = j.begin(); it != j.end(); ++it) {
      out += first ? "" : ", ";
      first = false;
      if (j.is_object()) out += ojson(it.key()).dump() + ": ";
      append_pretty(*it, indent, out);
    }
    out += j.is_array() ? "]" : "}";
    return;
  }
  const std::string pad(static_cast<size_t>(indent + 2), ' ');
  out += j.is_array() ? "[\n" : "{\n";
  bool first = true;
  for (auto it = j.begin(); it != j.end(); ++it) {
    out += first ? "" : ",\n";
    first = false;
    out += pad;
    if (j.is_object()) out += ojson(it.key()).dump() + ": ";
    append_pretty(*it, indent + 2, out);
  }
  out += "\n" + std::string(static_cast<size_t>(indent), ' ') + (j.is_array() ? "]" : "}");
}

}  // namespace

void write_file_atomically(const std::string& path, const std::string& content) {
  const std::string tmp = path + ".tmp." + std::to_string(static_cast<long>(::getpid()));
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) throw std::runtime_error("cannot write " + path + ": " + std::strerror(errno));
  const bool written = std::fwrite(content.data(), 1, content.size(), f) == content.size();
  const int write_errno = errno;
  const bool closed = std::fclose(f) == 0;
  if (!written || !closed) {
    std::remove(tmp.c_str());
    throw std::runtime_error("cannot write " + path + ": " + std::strerror(write_errno ? write_errno : EIO));
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::remove(tmp.c_str());
    throw std::runtime_error("cannot write " + path + ": " + ec.message());
  }
}

std::string solver_failure(const Simulation& sim) {
  // A run stopped far from the origin has no result either (its later frames did not run).
  if (!sim.stop_reason().empty()) return sim.stop_reason();
  // Refused substeps leave the state as it was; a few are survivable, most mean the sheet never moved
  // (a step far outside what the solver can take). Relaxation substeps add to the refusals, not to the count.
  const int64_t substeps = static_cast<int64_t>(sim.frame()) * sim.scenario().sim.substeps;
  const int64_t refused = solver_stats(sim).failures;
  if (substeps <= 0 || 2 * refused <= substeps) return "";
  return "the solver refused " + std::to_string(refused) + " of the run's " + std::to_string(substeps) +
         " substeps (a refused substep leaves the sheet where it was)";
}

bool build_result_json(const Simulation& sim, nlohmann::ordered_json& out, std::string* error) {
  const Sheet& sheet = sim.sheet();
  const std::vector<FrameStats>& stats = sim.frame_stats();
  Numbers num;

  // Triangle counts over the frames (the initial mesh when no frame ran).
  double tri_sum = 0;
  int32_t tri_max = 0;
  for (const FrameStats& f : stats) {
    tri_sum += f.triangles;
    tri_max = std::max(tri_max, f.triangles);
  }
  const double tri_avg = stats.empty() ? sheet.tris.size() : tri_sum / static_cast<double>(stats.size());
  if (stats.empty()) tri_max = sheet.tris.size();

  // Pieces from the per-triangle piece ids (topology), numbered densely from 0.
  int32_t piece_count = 0;
  for (const int32_t p : sheet.tris.piece) piece_count = std::max(piece_count, p + 1);
  std::vector<int32_t> piece_tris(piece_count, 0);
  std::vector<double> piece_area(piece_count, 0.0);
  std::vector<Vec3> piece_centroid(piece_count, Vec3::Zero());
  for (int32_t t = 0; t < sheet.tris.size(); ++t) {
    const int32_t p = sheet.tris.piece[t];
    if (p < 0) continue;
    const double a = sheet.tris.rest_area[t];
    const Tri& tri = sheet.tris.tri[t];
    ++piece_tris[p];
    piece_area[p] += a;
    piece_centroid[p] += a * (sheet.verts.x[tri[0]] + sheet.verts.x[tri[1]] + sheet.verts.x[tri[2]]) / 3.0;
  }

  ojson result;
  result["scenario"] = sim.scenario().name;
  result["status"] = "ok";  // replaced below when a number was not finite or the solver refused most substeps
  result["frames"] = sim.frame();
  result["threads"] = sim.threads();
  result["mesh"] = ojson{{"vertices", sheet.verts.size()},
                         {"triangles", sheet.tris.size()},
                         {"triangles_avg", num(tri_avg)},
                         {"triangles_max", tri_max},
                         {"pieces", piece_count}};

  ojson tears = ojson::array();
  for (const Tear& t : sheet.tears) {
    tears.push_back(ojson{
        {"id", t.id},
        {"parent", t.parent < 0 ? ojson(nullptr) : ojson(t.parent)},
        {"start", ojson{{"kind", start_kind_name(t.start_kind)}, {"frame", t.start_frame}, {"uv", num.uv(t.start_uv)}}},
        {"tips", num.path(t.tips)},
        {"detail", num.path(t.detail)},
        {"max_advance_per_frame", num(t.max_frame_advance)}});
  }
  result["tears"] = std::move(tears);

  ojson fingers = ojson::array();
  for (const Finger& f : sheet.fingers)
    fingers.push_back(ojson{{"name", f.name}, {"uv", num.uv(f.uv)}, {"max_force", num(f.max_force)},
                             {"force", num(f.reaction.norm())},
                             {"slips", f.slips}, {"let_go", f.let_go}});
  result["fingers"] = std::move(fingers);
  result["max_strain"] = num(sim.max_strain());
  result["max_strain_beyond_tips"] = num(sim.max_strain_beyond_tips());

  const TimingReport& tr = sim.timings();
  result["timings_ms"] = ojson{{"physics", num.stat(tr.physics)},
                               {"geometry", num.stat(tr.geometry)},
                               {"tearing", num.stat(tr.tearing)},
                               {"carving", num.stat(tr.carving)},
                               {"frame", num.stat(tr.frame)}};
  result["hash"] = sim.state_hash();

  // Extra keys (docs/result-format.md: more keys may be added).
  ojson systems = ojson::object();
  for (size_t i = 0; i < kSystems.size(); ++i) systems[kSystems[i].name] = num.stat(tr.systems[i]);
  result["systems_ms"] = std::move(systems);

  ojson regions{{"frames", stats.size()}};
  int32_t regions_max = 0, junctions_max = 0, candidates_max = 0;
  for (const FrameStats& f : stats) {
    regions_max = std::max(regions_max, f.regions);
    junctions_max = std::max(junctions_max, f.junctions);
    candidates_max = std::max(candidates_max, f.candidates);
  }
  regions["regions_max"] = regions_max;
  regions["junctions_max"] = junctions_max;
  regions["candidates_max"] = candidates_max;
  if (stats.empty()) {
    regions["last"] = nullptr;
  } else {
    const FrameStats& l = stats.back();
    regions["last"] = ojson{{"triangles", l.triangles}, {"regions", l.regions}, {"junctions", l.junctions},
                            {"candidates", l.candidates}};
  }
  result["regions_summary"] = std::move(regions);

  ojson pieces = ojson::array();
  for (int32_t p = 0; p < piece_count; ++p) {
    const Vec3 c = piece_area[p] > 0 ? Vec3(piece_centroid[p] / piece_area[p]) : Vec3::Zero();
    pieces.push_back(ojson{{"id", p},
                           {"triangles", piece_tris[p]},
                           {"area", num(piece_area[p])},
                           {"centroid", ojson::array({num(c.x()), num(c.y()), num(c.z())})}});
  }
  result["pieces"] = std::move(pieces);

  // The work of the implicit integrator: symbolic analyses
  // (after cuts or a change of the held set), numeric factorisations, spin-brake redos, substeps redone as
  // two halves, solves that needed a diagonal shift, and rejected substeps.
  if (const SelfContactStats* c = self_contact_stats(sim))
    result["self_contact"] = ojson{{"proximities", c->proximities}, {"repulsions", c->repulsions},
                                   {"collisions", c->collisions},   {"zones", c->zones},
                                   {"unresolved", c->unresolved},   {"queries", c->queries},
                                   {"ms", num(c->ms)}};
  const ImplicitStats solver = solver_stats(sim);
  result["solver"] = ojson{{"analyses", solver.analyses},
                           {"factorizations", solver.factorizations},
                           {"brakes", solver.brakes},
                           {"splits", solver.splits},
                           {"regularised", solver.regularised},
                           {"failures", solver.failures},
                           {"remeshes", sim.remesh_count()}};
  // Where the integrator's time went, ms summed over the run (wall time, so not part of the results).
  result["solver_ms"] = ojson{{"structure", num(solver.structure_ms)},
                              {"analysis", num(solver.analysis_ms)},
                              {"assembly", num(solver.assembly_ms)},
                              {"factorization", num(solver.factorization_ms)},
                              {"solve", num(solver.solve_ms)}};

  std::string reason = solver_failure(sim);
  if (!num.finite) reason += (reason.empty() ? "" : "; ") + std::string("non-finite numbers in the simulation state");
  if (error) *error = reason;
  if (reason.empty()) {
    out = std::move(result);
    return true;
  }
  result["status"] = "error";
  out = ojson::object();
  for (auto it = result.begin(); it != result.end(); ++it) {  // "error" right after "status"
    out[it.key()] = std::move(it.value());
    if (it.key() == "status") out["error"] = reason;
  }
  return false;
}

bool write_result_json(const Simulation& sim, const std::string& path, std::string* error) {
  ojson result;
  const bool ok = build_result_json(sim, result, error);
  std::string text;
  append_pretty(result, 0, text);
  write_file_atomically(path, text + "\n");
  return ok;
}

void write_svg(const Simulation& sim, const std::string& path) {
  const Sheet& sheet = sim.sheet();
  const Box box = pattern_box(sim);
  const Vec2 size = box.hi - box.lo;
  const double extent = std::max({size.x(), size.y(), 1e-6}) * 1000.0;  // mm
  const double margin = 0.08 * extent;
  const double width = size.x() * 1000.0 + 2 * margin, height = size.y() * 1000.0 + 2 * margin;
  // Pattern (m) → SVG (mm), v flipped so the sheet is upright.
  auto X = [&](const Vec2& p) { return finite_or_zero((p.x() - box.lo.x()) * 1000.0 + margin); };
  auto Y = [&](const Vec2& p) { return finite_or_zero((box.hi.y() - p.y()) * 1000.0 + margin); };
  const double thin = 0.0012 * extent, line = 0.003 * extent, thick = 0.007 * extent, dot = 0.009 * extent,
               font = 0.028 * extent;

  std::string s;
  s.reserve(256 + sheet.tris.size() * 48);
  appendf(s, "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 %.3f %.3f\" width=\"%.3fmm\" height=\"%.3fmm\">\n",
          width, height, width, height);
  s += "<title>papertear: " + xml_escape(sim.scenario().name) + ", frame " + std::to_string(sim.frame()) +
       "</title>\n";
  appendf(s, "<rect width=\"%.3f\" height=\"%.3f\" fill=\"white\"/>\n", width, height);

  // Triangles, one path per region kind (small file, one style each).
  const char* fills[4] = {"#d6efcc", "#e3d3f3", "#fcdfc2", "#f2f2f2"};  // flat, curved+, curved−, no region
  const char* names[4] = {"flat", "curved-positive", "curved-negative", "unassigned"};
  std::string paths[4];
  for (int32_t t = 0; t < sheet.tris.size(); ++t) {
    const int32_t r = t < static_cast<int32_t>(sheet.tris.region.size()) ? sheet.tris.region[t] : -1;
    const int kind = (r >= 0 && r < static_cast<int32_t>(sheet.regions.size()))
                         ? static_cast<int>(sheet.regions[r].kind)
                         : 3;
    const Tri& tri = sheet.tris.tri[t];
    const Vec2 &a = sheet.verts.rest[tri[0]], &b = sheet.verts.rest[tri[1]], &c = sheet.verts.rest[tri[2]];
    appendf(paths[kind], "M%.3f %.3fL%.3f %.3fL%.3f %.3fZ", X(a), Y(a), X(b), Y(b), X(c), Y(c));
  }
  appendf(s, "<g id=\"triangles\" stroke=\"#9a9a9a\" stroke-width=\"%.4f\" stroke-linejoin=\"round\">\n", thin);
  for (int k = 0; k < 4; ++k)
    if (!paths[k].empty())
      s += std::string("<path class=\"") + names[k] + "\" fill=\"" + fills[k] + "\" d=\"" + paths[k] + "\"/>\n";
  s += "</g>\n";

  std::string boundary;
  for (const auto& [a, b] : boundary_edges(sheet.tris.tri)) {
    const Vec2 &p = sheet.verts.rest[a], &q = sheet.verts.rest[b];
    appendf(boundary, "M%.3f %.3fL%.3f %.3f", X(p), Y(p), X(q), Y(q));
  }
  appendf(s, "<path id=\"boundary\" fill=\"none\" stroke=\"black\" stroke-width=\"%.4f\" stroke-linecap=\"round\" d=\"",
          line);
  s += boundary + "\"/>\n";

  // Tears: coarse path thick dark red, detail thin red on top.
  auto polyline = [&](const std::vector<Vec2>& pts, const char* colour, double w) {
    std::string p;
    for (const Vec2& q : pts) appendf(p, "%s%.3f,%.3f", p.empty() ? "" : " ", X(q), Y(q));
    std::string out;
    appendf(out, "<polyline fill=\"none\" stroke=\"%s\" stroke-width=\"%.4f\" stroke-linejoin=\"round\" stroke-linecap=\"round\" points=\"",
            colour, w);
    return out + p + "\"/>\n";
  };
  s += "<g id=\"tears\">\n";
  for (const Tear& t : sheet.tears) {
    if (t.tips.size() >= 2) s += polyline(t.tips, "#8b0000", thick);
    if (t.detail.size() >= 2) s += polyline(t.detail, "#ff2020", thin * 1.5);
  }
  s += "</g>\n";

  // Candidates: junction points yellow, inward-angle points sky blue.
  s += "<g id=\"candidates\" stroke=\"black\" stroke-width=\"" + std::to_string(thin) + "\">\n";
  for (int32_t v = 0; v < sheet.verts.size(); ++v) {
    const uint8_t f = sheet.verts.flags[v];
    const Vec2& p = sheet.verts.rest[v];
    if (f & kJunction) appendf(s, "<circle class=\"junction\" cx=\"%.3f\" cy=\"%.3f\" r=\"%.3f\" fill=\"#ffd700\"/>\n", X(p), Y(p), dot * 0.8);
    if (f & kInward) appendf(s, "<circle class=\"inward\" cx=\"%.3f\" cy=\"%.3f\" r=\"%.3f\" fill=\"#87ceeb\"/>\n", X(p), Y(p), dot * 0.6);
  }
  s += "</g>\n";

  // Active tips: a dark red ring.
  s += "<g id=\"tips\" fill=\"none\" stroke=\"#8b0000\" stroke-width=\"" + std::to_string(line) + "\">\n";
  for (const Tip& tip : sheet.tips) {
    if (tip.vertex < 0 || tip.vertex >= sheet.verts.size()) continue;
    const Vec2& p = sheet.verts.rest[tip.vertex];
    appendf(s, "<circle cx=\"%.3f\" cy=\"%.3f\" r=\"%.3f\"/>\n", X(p), Y(p), dot * 1.3);
  }
  s += "</g>\n";

  // Fingers: red dots with their names, a pad's disc as a red ring.
  s += "<g id=\"fingers\" fill=\"#e00000\" font-family=\"sans-serif\" font-size=\"" + std::to_string(font) + "\">\n";
  for (const Finger& f : sheet.fingers) {
    if (f.vertex >= 0 && f.pad_radius > 0)
      appendf(s, "<circle class=\"pad\" cx=\"%.3f\" cy=\"%.3f\" r=\"%.3f\" fill=\"none\" stroke=\"#e00000\" stroke-width=\"%.4f\"/>",
              X(f.uv), Y(f.uv), finite_or_zero(f.pad_radius * 1000.0), line);
    appendf(s, "<circle cx=\"%.3f\" cy=\"%.3f\" r=\"%.3f\"/>", X(f.uv), Y(f.uv), dot);
    appendf(s, "<text x=\"%.3f\" y=\"%.3f\">", X(f.uv) + 1.3 * dot, Y(f.uv) - 1.3 * dot);
    s += xml_escape(f.name) + "</text>\n";
  }
  s += "</g>\n</svg>\n";
  write_file_atomically(path, s);
}

void write_obj(const Simulation& sim, const std::string& path) {
  const Sheet& sheet = sim.sheet();
  // vt in the texture's frame (origin, pixel size × resolution) so the PNGs of engine/texture_export.hpp
  // map onto the mesh; the outline's bounding box when there is no texture.
  const DetailParams& dp = detail_params(sim);
  Box box = pattern_box(sim);
  if (dp.width > 0 && dp.height > 0 && dp.pixel_size > 0) {
    box.lo = dp.origin;
    box.hi = dp.origin + dp.pixel_size * Vec2(dp.width, dp.height);
  }
  const Vec2 size = (box.hi - box.lo).cwiseMax(Vec2::Constant(1e-12));
  std::string s;
  s.reserve(64 + sheet.verts.size() * 64 + sheet.tris.size() * 32);
  s += "# papertear " + sim.scenario().name + " frame " + std::to_string(sim.frame()) + "\n";
  s += "o sheet\n";
  for (const Vec3& x : sheet.verts.x)
    appendf(s, "v %.9g %.9g %.9g\n", finite_or_zero(x.x()), finite_or_zero(x.y()), finite_or_zero(x.z()));
  for (const Vec2& r : sheet.verts.rest)
    appendf(s, "vt %.9g %.9g\n", finite_or_zero((r.x() - box.lo.x()) / size.x()),
            finite_or_zero((r.y() - box.lo.y()) / size.y()));
  for (const Tri& t : sheet.tris.tri)
    appendf(s, "f %d/%d %d/%d %d/%d\n", t[0] + 1, t[0] + 1, t[1] + 1, t[1] + 1, t[2] + 1, t[2] + 1);
  write_file_atomically(path, s);
}

struct TexturedObjWriter::State {
  std::string dir_;
  PatternStyle style_;
  bool paper_written_ = false;
  CarvedAtlas atlas_;
  int64_t atlas_segments_ = -1;
  std::string carved_name_;
  int32_t carved_written_ = 0;
};

TexturedObjWriter::TexturedObjWriter(std::string dir) : TexturedObjWriter(std::move(dir), PatternStyle{}) {}
TexturedObjWriter::TexturedObjWriter(std::string dir, const PatternStyle& style) : state_(std::make_unique<State>()) {
  state_->dir_ = std::move(dir);
  state_->style_ = style;
}
TexturedObjWriter::~TexturedObjWriter() = default;
int32_t TexturedObjWriter::carved_textures_written() const { return state_->carved_written_; }
const std::string& TexturedObjWriter::carved_texture() const { return state_->carved_name_; }

double estimated_obj_bytes(const Simulation& sim, int64_t frames) {
  const DetailParams& dp = detail_params(sim);
  // paper.png: the demo's 2100 x 2970 px texture took 7.1 MB, 1.15 B a pixel at compression level 1.
  const double paper = 1.5 * static_cast<double>(dp.width) * static_cast<double>(dp.height);
  const double frame = 256 + 64.0 * sim.sheet().verts.size() + 48.0 * sim.sheet().tris.size() + 256;
  return paper + frame * static_cast<double>(frames);
}

namespace {
// A support strip beyond lip edge a→b of a triangle on tear side `label`.
struct Strip {
  int32_t label, a, b;
  Vec2 ra, rb;  // outer corners, pattern
  Vec3 xa, xb;  // outer corners, 3D
};

// The support strips: lip edges (boundary edges of a labelled triangle whose two ends lie on a tear's lip)
// pushed outwards in the pattern by the strip width w, carried to 3D by the triangle's deformation gradient
// F = [x1 − x0, x2 − x0] · rest_inv. `side`: the side label of each triangle.
std::vector<Strip> support_strips(const Sheet& sheet, const std::vector<int32_t>& side, double w) {
  const int32_t nt = sheet.tris.size();
  std::vector<Strip> strips;
  std::vector<std::pair<uint64_t, int32_t>> edges;  // (edge key, triangle * 3 + corner)
  edges.reserve(static_cast<size_t>(nt) * 3);
  for (int32_t t = 0; t < nt; ++t)
    for (int k = 0; k < 3; ++k) {
      const int32_t a = sheet.tris.tri[t][k], b = sheet.tris.tri[t][(k + 1) % 3];
      edges.push_back({(uint64_t(uint32_t(std::min(a, b))) << 32) | uint32_t(std::max(a, b)), t * 3 + k});
    }
  std::sort(edges.begin(), edges.end());
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    while (j < edges.size() && edges[j].first == edges[i].first) ++j;
    const int32_t t = edges[i].second / 3, k = edges[i].second % 3;
    if (j - i == 1 && side[static_cast<size_t>(t)] > 0) {
      const Tri& tri = sheet.tris.tri[t];
      const int32_t a = tri[k], b = tri[(k + 1) % 3];
      const int32_t tear = label_tear(side[static_cast<size_t>(t)]);
      if (sheet.verts.tear[a] == tear && sheet.verts.tear[b] == tear) {
        const Vec2 &ra = sheet.verts.rest[a], &rb = sheet.verts.rest[b];
        const Vec2 e = rb - ra;
        const double len = e.norm();
        if (len > 0) {
          const Vec2 out = Vec2(e.y(), -e.x()) / len * w;  // right of a→b: outside a counter-clockwise triangle
          Eigen::Matrix<double, 3, 2> X;
          X.col(0) = sheet.verts.x[tri[1]] - sheet.verts.x[tri[0]];
          X.col(1) = sheet.verts.x[tri[2]] - sheet.verts.x[tri[0]];
          Vec3 off = X * sheet.tris.rest_inv[t] * out;
          if (!off.allFinite()) off = Vec3::Zero();
          strips.push_back({side[static_cast<size_t>(t)], a, b, ra + out, rb + out, sheet.verts.x[a] + off,
                            sheet.verts.x[b] + off});
        }
      }
    }
    i = j;
  }
  return strips;
}

// Atlas windows: per label, the pixel box of its triangles and strips, one pixel of margin, snapped to
// label tiles (so small changes of the lip keep the layout and the PNG), clipped to the texture.
std::vector<std::pair<int32_t, PixelRect>> atlas_windows(const Sheet& sheet, const std::vector<int32_t>& side,
                                                         const std::vector<Strip>& strips, const DetailParams& dp) {
  const int32_t nt = sheet.tris.size();
  std::vector<int32_t> labels;
  for (int32_t t = 0; t < nt; ++t)
    if (side[static_cast<size_t>(t)] > 0) labels.push_back(side[static_cast<size_t>(t)]);
  std::sort(labels.begin(), labels.end());
  labels.erase(std::unique(labels.begin(), labels.end()), labels.end());
  std::vector<Box> boxes(labels.size());
  auto box_of = [&](int32_t label) -> Box& {
    return boxes[static_cast<size_t>(std::lower_bound(labels.begin(), labels.end(), label) - labels.begin())];
  };
  for (int32_t t = 0; t < nt; ++t)
    if (side[static_cast<size_t>(t)] > 0)
      for (int32_t v : sheet.tris.tri[t]) box_of(side[static_cast<size_t>(t)]).add(sheet.verts.rest[v]);
  for (const Strip& s : strips) {
    box_of(s.label).add(s.ra);
    box_of(s.label).add(s.rb);
  }
  std::vector<std::pair<int32_t, PixelRect>> windows;
  for (size_t k = 0; k < labels.size(); ++k) {
    if (!boxes[k].valid()) continue;
    const Vec2 lo = (boxes[k].lo - dp.origin) / dp.pixel_size, hi = (boxes[k].hi - dp.origin) / dp.pixel_size;
    auto snap_down = [](double v) { return static_cast<int32_t>(std::floor((v - 1) / kTileSize)) * kTileSize; };
    auto snap_up = [](double v) { return static_cast<int32_t>(std::ceil((v + 1) / kTileSize)) * kTileSize; };
    const int32_t x0 = std::clamp(snap_down(lo.x()), 0, dp.width), y0 = std::clamp(snap_down(lo.y()), 0, dp.height);
    const int32_t x1 = std::clamp(snap_up(hi.x()), 0, dp.width), y1 = std::clamp(snap_up(hi.y()), 0, dp.height);
    if (x1 > x0 && y1 > y0) windows.push_back({labels[k], PixelRect{x0, y0, x1 - x0, y1 - y0}});
  }
  return windows;
}

// MTL: both materials, diffuse and alpha from the same RGBA image; "carved" only when `carved`.
std::string textured_mtl(const Simulation& sim, bool carved, const std::string& carved_name) {
  std::string mtl = "# papertear " + sim.scenario().name + " frame " + std::to_string(sim.frame()) + "\n";
  auto material = [&](const char* name, const std::string& png) {
    mtl += std::string("newmtl ") + name + "\nKa 1 1 1\nKd 1 1 1\nKs 0 0 0\nd 1\nillum 1\n";
    mtl += "map_Kd " + png + "\nmap_d " + png + "\n";
  };
  material("paper", "paper.png");
  if (carved) material("carved", carved_name);
  return mtl;
}

// What the textured OBJ of one frame is made of.
struct TexturedObjParts {
  const std::string& stem;           // of the .mtl it names
  const std::vector<int32_t>& side;  // side label of each triangle, 0 away from the tears
  const std::vector<Strip>& strips;
  const CarvedAtlas& atlas;
  bool carved;  // the MTL has the carved material
};

// OBJ: mesh vertices then strip corners; texture coordinates per (vertex, material patch).
std::string textured_obj(const Simulation& sim, const TexturedObjParts& parts) {
  const Sheet& sheet = sim.sheet();
  const DetailParams& dp = detail_params(sim);
  const int32_t nv = sheet.verts.size(), nt = sheet.tris.size();
  const std::string& stem = parts.stem;
  const std::vector<int32_t>& side = parts.side;
  const std::vector<Strip>& strips = parts.strips;
  const CarvedAtlas& atlas = parts.atlas;
  const Vec2 tex_size = dp.pixel_size * Vec2(dp.width, dp.height);
  std::string s;
  s.reserve(256 + static_cast<size_t>(nv) * 64 + static_cast<size_t>(nt) * 48 + strips.size() * 200);
  s += "# papertear " + sim.scenario().name + " frame " + std::to_string(sim.frame()) + "\n";
  appendf(s, "# %d mesh vertices (vt 1..%d: their paper coordinates), %d support-strip corners\n", nv, nv,
          static_cast<int32_t>(2 * strips.size()));
  s += "mtllib " + stem + ".mtl\no sheet\n";
  for (const Vec3& x : sheet.verts.x)
    appendf(s, "v %.9g %.9g %.9g\n", finite_or_zero(x.x()), finite_or_zero(x.y()), finite_or_zero(x.z()));
  for (const Strip& st : strips)
    for (const Vec3* x : {&st.xa, &st.xb})
      appendf(s, "v %.9g %.9g %.9g\n", finite_or_zero(x->x()), finite_or_zero(x->y()), finite_or_zero(x->z()));
  int32_t vt_count = 0;
  std::vector<std::pair<uint64_t, int32_t>> vt_index;  // (label << 32 | vertex) → vt, sorted on demand
  std::string vts, faces_paper, faces_carved;
  auto add_vt = [&](const Vec2& uv) {
    appendf(vts, "vt %.9g %.9g\n", finite_or_zero(uv.x()), finite_or_zero(uv.y()));
    return ++vt_count;
  };
  // Paper coordinates of every mesh vertex first (vt i = vertex i, as write_obj).
  for (const Vec2& r : sheet.verts.rest) add_vt(Vec2((r.x() - dp.origin.x()) / tex_size.x(), (r.y() - dp.origin.y()) / tex_size.y()));
  auto carved_vt = [&](int32_t label, int32_t v, const Vec2& r) {
    const uint64_t key = (uint64_t(uint32_t(label)) << 32) | uint32_t(v);
    auto it = std::lower_bound(vt_index.begin(), vt_index.end(), std::make_pair(key, INT32_MIN));
    if (it != vt_index.end() && it->first == key) return it->second;
    const int32_t id = add_vt(atlas.uv(dp, *atlas.find(label), r));
    vt_index.insert(it, {key, id});
    return id;
  };
  for (int32_t t = 0; t < nt; ++t) {
    const Tri& tri = sheet.tris.tri[t];
    const int32_t label = side[static_cast<size_t>(t)];
    if (label > 0 && atlas.find(label)) {
      int32_t vt[3];
      for (int k = 0; k < 3; ++k) vt[k] = carved_vt(label, tri[k], sheet.verts.rest[tri[k]]);
      appendf(faces_carved, "f %d/%d %d/%d %d/%d\n", tri[0] + 1, vt[0], tri[1] + 1, vt[1], tri[2] + 1, vt[2]);
    } else {
      appendf(faces_paper, "f %d/%d %d/%d %d/%d\n", tri[0] + 1, tri[0] + 1, tri[1] + 1, tri[1] + 1, tri[2] + 1,
              tri[2] + 1);
    }
  }
  for (size_t k = 0; k < strips.size(); ++k) {
    const Strip& st = strips[k];
    const AtlasPatch* patch = atlas.find(st.label);
    if (!patch) continue;
    const int32_t a = st.a + 1, b = st.b + 1;
    const int32_t oa = nv + 2 * static_cast<int32_t>(k) + 1, ob = oa + 1;
    const int32_t ta = carved_vt(st.label, st.a, sheet.verts.rest[st.a]);
    const int32_t tb = carved_vt(st.label, st.b, sheet.verts.rest[st.b]);
    const int32_t toa = add_vt(atlas.uv(dp, *patch, st.ra)), tob = add_vt(atlas.uv(dp, *patch, st.rb));
    // a → b runs counter-clockwise around its triangle; the strip (b, a, oa, ob) keeps that orientation.
    appendf(faces_carved, "f %d/%d %d/%d %d/%d\nf %d/%d %d/%d %d/%d\n", b, tb, a, ta, oa, toa, b, tb, oa, toa, ob, tob);
  }
  s += vts;
  s += "usemtl paper\n" + faces_paper;
  if (parts.carved && !faces_carved.empty()) s += "usemtl carved\n" + faces_carved;
  return s;
}
}  // namespace

void TexturedObjWriter::write(const Simulation& sim, const std::string& stem) {
  State& st = *state_;
  namespace fs = std::filesystem;
  const Sheet& sheet = sim.sheet();
  const DetailParams& dp = detail_params(sim);
  const fs::path dir(st.dir_);
  if (dp.width <= 0 || dp.height <= 0 || !(dp.pixel_size > 0)) {  // no texture: the plain mesh
    write_obj(sim, (dir / (stem + ".obj")).string());
    return;
  }
  const std::vector<Vec2>& outline = sim.scenario().outline;
  if (!st.paper_written_) {
    std::vector<uint8_t> rgba;
    render_carved_texture_rgba(outline, carve_state(sim), dp, fiber_field(sim), 0, st.style_, rgba);
    write_rgba_png((dir / "paper.png").string(), dp.width, dp.height, rgba);
    st.paper_written_ = true;
  }

  // Side labels of the triangles along the tears, and their support strips.
  std::vector<int32_t> side;
  assign_triangle_sides(sheet.verts.rest, sheet.verts.tear, sheet.tris.tri, sheet.tears, side);
  const std::vector<Strip> strips = support_strips(sheet, side, support_strip_width(dp));

  const CarvedAtlas atlas = pack_carved_atlas(atlas_windows(sheet, side, strips, dp));
  const int64_t segments = carve_state(sim).carved_segments;
  if (!atlas.patches.empty() && (st.carved_name_.empty() || !(atlas == st.atlas_) || segments != st.atlas_segments_)) {
    char name[40];
    std::snprintf(name, sizeof name, "carved_%04d.png", sim.frame());
    std::vector<uint8_t> rgba;
    render_carved_atlas(atlas, outline, sheet.tears, carve_state(sim), dp, fiber_field(sim), st.style_, rgba);
    write_rgba_png((dir / name).string(), atlas.width, atlas.height, rgba);
    st.carved_name_ = name;
    st.atlas_ = atlas;
    st.atlas_segments_ = segments;
    ++st.carved_written_;
  }

  const bool carved = !atlas.patches.empty();
  write_file_atomically((dir / (stem + ".mtl")).string(), textured_mtl(sim, carved, st.carved_name_));
  write_file_atomically((dir / (stem + ".obj")).string(),
                        textured_obj(sim, TexturedObjParts{stem, side, strips, atlas, carved}));
}

}  // namespace pt
