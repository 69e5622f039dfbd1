// Outputs of a run (DESIGN §7): result.json, the 2D pattern as SVG, the mesh as OBJ.
// Every file is written atomically (temporary file, then rename), so a failed run never leaves a
// partial file that looks like a result.
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <string>

namespace pt {

class Simulation;

// The result document: the keys of DESIGN §7 in that order, then "systems_ms", "regions_summary" and
// "pieces". A non-finite number is written as null and makes "status" "error". Returns true when every
// number was finite (status "ok"). Call Simulation::flush() first so tears' detail paths are complete.
bool build_result_json(const Simulation& sim, nlohmann::ordered_json& out);

// Writes build_result_json to `path` (pretty-printed). Returns its status (true: "ok"). Throws
// std::runtime_error when the file cannot be written.
bool write_result_json(const Simulation& sim, const std::string& path);

// The 2D pattern, upright (v up), viewBox in millimetres: triangles coloured by region kind, boundary,
// candidates (junction yellow, inward sky blue), fingers with names, tears (coarse thick dark red,
// detail thin red) and active tips. Throws std::runtime_error on I/O failure.
void write_svg(const Simulation& sim, const std::string& path);

// The mesh now: v = 3D positions, vt = pattern positions normalised to the texture's extent (the
// outline's bounding box, DESIGN §5.6), f = triangles. Throws std::runtime_error on I/O failure.
void write_obj(const Simulation& sim, const std::string& path);

// Writes `content` to `path` through a temporary file in the same directory and a rename.
void write_file_atomically(const std::string& path, const std::string& content);

}  // namespace pt
