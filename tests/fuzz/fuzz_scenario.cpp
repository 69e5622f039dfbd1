// libFuzzer target (issue 9): the scenario loader on arbitrary bytes. parse_scenario (which validates) may
// only ever throw InputError or GeometryError; anything else (another exception, a sanitizer report, a
// crash, a hang) is a finding. A scenario that loads must also pass validate_scenario again (idempotent)
// and its InputError messages must be one line. A scenario that loads is then meshed as the engine meshes
// it (the outline, the target, the seed and rotation, the fingers as required vertices): the mesher may
// refuse it with a one-line GeometryError only, and a mesh it makes must keep its promises (counter-
// clockwise triangles, at most max_mesh_triangles of them, a vertex at each required point). Requests
// above kMeshedTriangles are validated only, so an execution stays short.
#include "engine/scenario.hpp"
#include "systems/mesh/meshing.hpp"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

namespace {

[[noreturn]] void finding(const char* what, const std::string& detail) {
  std::fprintf(stderr, "fuzz_scenario: %s: %s\n", what, detail.c_str());
  std::abort();
}

void check_message(const char* what) {
  const std::string m(what);
  if (m.empty()) finding("empty error message", "");
  if (m.find('\n') != std::string::npos) finding("multi-line error message", m);
}

constexpr int32_t kMeshedTriangles = 4000;

void mesh_as_the_engine_does(const pt::Scenario& s) {
  if (s.triangles > kMeshedTriangles) return;
  pt::MeshRequest request;
  request.outline = s.outline;
  request.target_triangles = s.triangles;
  request.seed = s.mesh_seed;
  request.rotation_deg = s.mesh_rotation_deg;
  for (const pt::FingerSpec& f : s.fingers)
    if (f.attach <= 0) request.required_points.push_back(f.at);
  std::vector<pt::Vec2> rest;
  std::vector<pt::Tri> tri;
  std::vector<int32_t> required;
  try {
    pt::mesh_outline(request, rest, tri, required);
  } catch (const pt::GeometryError& e) {
    check_message(e.what());
    return;
  }
  const int64_t points = static_cast<int64_t>(s.outline.size() + request.required_points.size());
  if (static_cast<int64_t>(tri.size()) > pt::max_mesh_triangles(s.triangles, points))
    finding("more triangles than max_mesh_triangles", std::to_string(tri.size()));
  for (const pt::Tri& t : tri) {
    const pt::Vec2 a = rest[t[1]] - rest[t[0]], b = rest[t[2]] - rest[t[0]];
    if (!(a.x() * b.y() - a.y() * b.x() > 0)) finding("a triangle that is not counter-clockwise", "");
  }
  if (required.size() != request.required_points.size()) finding("required points without a vertex", "");
  // A required point within the outline's snap distance of an outline vertex or edge is placed there.
  const double snap = 1.000001 * pt::outline_snap_distance(s.outline) + 1e-12;
  for (size_t i = 0; i < required.size(); ++i)
    if (required[i] < 0 || required[i] >= static_cast<int32_t>(rest.size()) ||
        (rest[required[i]] - request.required_points[i]).norm() > snap)
      finding("a required point not at its vertex", std::to_string(i));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const pt::Scenario s = pt::parse_scenario(text, "fuzz.json");
    try {
      pt::validate_scenario(s);
    } catch (const std::exception& e) {
      finding("a parsed scenario fails validate_scenario", e.what());
    }
    mesh_as_the_engine_does(s);
  } catch (const pt::InputError& e) {
    check_message(e.what());
  } catch (const pt::GeometryError& e) {
    check_message(e.what());
  } catch (const std::exception& e) {
    finding("unexpected exception", e.what());
  } catch (...) {
    finding("unexpected non-std exception", "");
  }
  return 0;
}
