#include "engine/sheet_builder.hpp"

#include "systems/mesh/meshing.hpp"
#include "systems/physics/fingers.hpp"
#include "systems/common/pattern_geometry.hpp"
#include "systems/common/topology.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace pt {

namespace {
void bounding_box(const std::vector<Vec2>& outline, Vec2& lo, Vec2& hi) {
  lo = hi = outline.front();
  for (const Vec2& p : outline) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
}

// `sheet.hand_lines`: a hand's fingers hold the sheet along the line between them, where it pivots as the
// hand turns or the sheet bends away from it (an arch held at two points of each end). Flat triangles fold
// without stretching only along their edges, so the line becomes a chain of mesh edges; across it the
// straddling triangles lock (docs/physics.md, "Fingers"). Consecutive fingers of a hand in its listed
// order; a line that leaves the sheet or crosses an earlier one is left to the mesh, as is a finger put on
// later (it has no vertex yet).
void hand_line_segments(const Scenario& scenario, const std::vector<int32_t>& required_of, MeshRequest& request) {
  const auto required_point = [&](const std::string& name) {
    for (size_t i = 0; i < scenario.fingers.size(); ++i)
      if (scenario.fingers[i].name == name) return required_of[i];
    return -1;
  };
  for (const HandSpec& hand : scenario.hands)
    for (size_t k = 1; k < hand.fingers.size(); ++k) {
      const int32_t a = required_point(hand.fingers[k - 1]), b = required_point(hand.fingers[k]);
      if (a < 0 || b < 0) continue;
      request.required_segments.push_back({a, b});
      if (!segment_problem(request, request.required_segments.size() - 1).empty()) request.required_segments.pop_back();
    }
}
// Pads (systems/physics/fingers.hpp): a ring of six points at the pad's radius around each finger put on
// from the start, so that every mesh holds the same disc. A point outside the sheet, within a quarter of the
// radius of its outline or of a required segment, or within half of it of another required point is left
// out (it would make slivers); the pad then holds what the mesh has there.
void pad_rings(const Scenario& scenario, MeshRequest& request) {
  constexpr int kRingPoints = 6;
  for (const FingerSpec& finger : scenario.fingers) {
    const double r = finger.pad;
    if (finger.attach > 0 || !(r > 0)) continue;
    for (int k = 0; k < kRingPoints; ++k) {
      const double a = 2 * std::numbers::pi * k / kRingPoints;
      const Vec2 q = finger.at + r * Vec2(std::cos(a), std::sin(a));
      if (!point_in_polygon(request.outline, q)) continue;
      double clearance2 = std::numeric_limits<double>::infinity();
      const std::vector<Vec2>& o = request.outline;
      for (size_t e = 0; e < o.size(); ++e)
        clearance2 = std::min(clearance2, point_segment_distance2(q, o[e], o[(e + 1) % o.size()]));
      for (const auto& [a_index, b_index] : request.required_segments)
        clearance2 = std::min(clearance2, point_segment_distance2(q, request.required_points[a_index],
                                                                  request.required_points[b_index]));
      if (clearance2 < r * r / 16) continue;
      bool crowded = false;
      for (const Vec2& p : request.required_points) crowded = crowded || (p - q).squaredNorm() < r * r / 4;
      if (!crowded) request.required_points.push_back(q);
    }
  }
}
}  // namespace

Sheet build_sheet(const Scenario& scenario) {
  MeshRequest request;
  request.outline = scenario.outline;
  request.target_triangles = scenario.triangles;
  request.seed = scenario.mesh_seed;
  request.rotation_deg = scenario.mesh_rotation_deg;
  // Fingers put on from the start get a mesh vertex; later ones get theirs inserted when they attach
  // (as in the interactive session that recorded them, so a replay meets the same mesh).
  std::vector<int32_t> required_of(scenario.fingers.size(), -1);
  for (size_t i = 0; i < scenario.fingers.size(); ++i)
    if (scenario.fingers[i].attach <= 0) {
      required_of[i] = static_cast<int32_t>(request.required_points.size());
      request.required_points.push_back(scenario.fingers[i].at);
    }

  if (scenario.hand_lines) hand_line_segments(scenario, required_of, request);
  pad_rings(scenario, request);

  std::vector<Vec2> rest;
  std::vector<Tri> tri;
  std::vector<int32_t> required_vertex;
  mesh_outline(request, rest, tri, required_vertex);

  Sheet sheet;
  sheet.material = scenario.material;
  const int32_t nv = static_cast<int32_t>(rest.size());
  sheet.verts.resize(nv);
  sheet.verts.rest = rest;
  for (int32_t i = 0; i < nv; ++i) sheet.verts.x[i] = Vec3(rest[i].x(), rest[i].y(), 0.0);
  sheet.tris.resize(static_cast<int32_t>(tri.size()));
  sheet.tris.tri = tri;

  for (size_t i = 0; i < scenario.fingers.size(); ++i) {
    const FingerSpec& spec = scenario.fingers[i];
    Finger f;
    f.name = spec.name;
    f.uv = spec.at;
    f.vertex = required_of[i] >= 0 ? required_vertex[required_of[i]] : -1;
    f.keys = spec.keys;
    key_interpolation_from_name(spec.interpolation, f.interpolation);  // validated
    f.attach_time = spec.attach;
    f.release_time = spec.release;
    f.grip = spec.grip;
    f.pad_radius = spec.pad;
    f.start = Vec3(spec.at.x(), spec.at.y(), 0.0);
    f.target = f.start;
    sheet.fingers.push_back(f);
    if (f.vertex >= 0) sheet.verts.flags[f.vertex] |= kFinger;
  }
  for (const HandSpec& spec : scenario.hands) {
    Hand h;
    h.name = spec.name;
    h.keys = spec.keys;
    key_interpolation_from_name(spec.interpolation, h.interpolation);  // validated
    for (const std::string& name : spec.fingers)
      for (size_t i = 0; i < sheet.fingers.size(); ++i)
        if (sheet.fingers[i].name == name) {
          h.fingers.push_back(static_cast<int32_t>(i));
          sheet.fingers[i].hand = static_cast<int32_t>(sheet.hands.size());
        }
    hand_centroid_of_starts(sheet.fingers, h);
    sheet.hands.push_back(h);
  }
  for (size_t i = 0; i < sheet.fingers.size(); ++i) grab_pad(sheet.verts, sheet.hands, 0.0, i, sheet.fingers);
  refresh_after_topology_change(sheet);
  return sheet;
}

std::array<int32_t, 2> texture_size(const Scenario& scenario) {
  if (scenario.detail.texture[0] > 0 && scenario.detail.texture[1] > 0) return scenario.detail.texture;
  Vec2 lo, hi;
  bounding_box(scenario.outline, lo, hi);
  const Vec2 size = hi - lo;
  return {std::max(1, static_cast<int32_t>(std::ceil(size.x() / 1e-4))),
          std::max(1, static_cast<int32_t>(std::ceil(size.y() / 1e-4)))};
}

FiberField make_fiber_field(const Scenario& scenario) {
  FiberField f;
  f.seed = scenario.material.fiber_seed;
  f.feature_size = scenario.material.fiber_scale;
  Vec2 lo, hi;
  bounding_box(scenario.outline, lo, hi);
  f.origin = lo;
  const auto size = texture_size(scenario);
  // Square pixels: the larger of the two spacings covers the whole box.
  f.pixel_size = std::max((hi.x() - lo.x()) / size[0], (hi.y() - lo.y()) / size[1]);
  return f;
}

}  // namespace pt
