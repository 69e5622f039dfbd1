// Outputs of a run (docs/result-format.md): result.json, the 2D pattern as SVG, the mesh as OBJ.
// Every file is written atomically (temporary file, then rename), so a failed run never leaves a
// partial file that looks like a result.
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <cstdint>
#include <memory>
#include <string>

namespace pt {

class Simulation;
struct PatternStyle;  // engine/texture_export.hpp

// The result document: the keys of docs/result-format.md in that order, then "systems_ms", "regions_summary"
// and "pieces". "status" is "error", with the reason in "error" (after "status"; also in `*error` when
// given), when a number was not finite (it is written as null) or when the solver refused more than half of
// the run's substeps (the sheet stood still: not a result). Returns true when the status is "ok". Call
// Simulation::flush() first so tears' detail paths are complete.
bool build_result_json(const Simulation& sim, nlohmann::ordered_json& out, std::string* error = nullptr);

// Writes build_result_json to `path` (pretty-printed). Returns its status (true: "ok"). Throws
// std::runtime_error when the file cannot be written.
bool write_result_json(const Simulation& sim, const std::string& path, std::string* error = nullptr);

// "" when the solver did its work; else why the run is not a result: the simulation stopped with a vertex
// beyond ±kMaxSheetPosition (Simulation::stop_reason), or more than half of frames × substeps refused ("the
// solver refused 30 of the run's 30 substeps ...").
std::string solver_failure(const Simulation& sim);

// The 2D pattern, upright (v up), viewBox in millimetres: triangles coloured by region kind, boundary,
// candidates (junction yellow, inward sky blue), fingers with names, tears (coarse thick dark red,
// detail thin red) and active tips. Throws std::runtime_error on I/O failure.
void write_svg(const Simulation& sim, const std::string& path);

// The mesh now: v = 3D positions, vt = pattern positions normalised to the texture's extent (the
// outline's bounding box, docs/architecture.md "Details"), f = triangles. Throws std::runtime_error on
// I/O failure.
void write_obj(const Simulation& sim, const std::string& path);

// Textured OBJ sequence (`run --obj`, docs/result-format.md, paper §6.2): per frame <stem>.obj + <stem>.mtl
// in `dir`. Two materials: "paper" (paper.png, the whole texture, written once: triangles away from the
// tears) and "carved" (carved_<frame>.png, the atlas of texture_export.hpp: one patch per tear side present,
// alpha 0 beyond the detailed path for that side). Triangles along a tear get support strips (§6.2, Fig. 11):
// a quad of support_strip_width beyond each lip edge, in the triangle's plane, textured from the same patch,
// so the detail beyond the coarse edge shows. The atlas PNG is rewritten only when the carving or the atlas
// layout (the lip triangles) changed; frames in between reference the last one. Call Simulation::flush()
// before write() so the last frame's segments are carved. Throws std::runtime_error.
class TexturedObjWriter {
 public:
  explicit TexturedObjWriter(std::string dir);
  TexturedObjWriter(std::string dir, const PatternStyle& style);
  ~TexturedObjWriter();
  void write(const Simulation& sim, const std::string& stem);
  int32_t carved_textures_written() const;
  const std::string& carved_texture() const;  // current atlas file, "" if none

 private:
  // The atlas and style are engine/texture_export.hpp's types, which this header does not include.
  struct State;
  std::unique_ptr<State> state_;
};

// Estimated bytes `frames` frames of TexturedObjWriter take on disk for the sheet as it is now: paper.png
// once, and per frame the OBJ (64 B a vertex, 48 a triangle: the writer's own reservation, above the
// measured 25 kB of the demo's 248 vertices and 426 triangles) and MTL. Carved atlases come on top while
// tears are carved (421 kB each for the demo's), so this is a lower estimate of a tearing run.
double estimated_obj_bytes(const Simulation& sim, int64_t frames);

// Writes `content` to `path` through a temporary file in the same directory and a rename.
void write_file_atomically(const std::string& path, const std::string& content);

}  // namespace pt
