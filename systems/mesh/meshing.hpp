// Meshing: a counter-clockwise outline polygon (pattern, meters) becomes a quality triangulation
// (CGAL constrained Delaunay + Delaunay refinement, kept inside meshing.cpp) of about
// `target_triangles` triangles, with a vertex exactly at every required point (finger positions).
#pragma once

#include "components/errors.hpp"
#include "components/sheet.hpp"

#include <array>
#include <stdexcept>
#include <string>
#include <vector>

namespace pt {

struct MeshRequest {
  std::vector<Vec2> outline;           // counter-clockwise simple polygon, ≥ 3 vertices, meters
  std::vector<Vec2> required_points;   // must become mesh vertices (inside or on the outline)
  // Pairs of required points (indices) whose straight segment must become a chain of mesh edges: each
  // inside the outline, crossing no other. A hand's fingers hold the sheet along such a line.
  std::vector<std::array<int32_t, 2>> required_segments;
  int32_t target_triangles = 400;      // the result is within ±20% of this
  uint64_t seed = 0;                   // 0: default mesh; others: a different irregular mesh of the same sheet
  double rotation_deg = 0;             // orientation of the meshing frame
  double min_angle_deg = 20;           // quality bound
};

// Outputs: `rest` (pattern positions), `tri` (counter-clockwise), `required_vertex[i]` the vertex id
// placed at required_points[i]. Throws GeometryError on a non-simple, clockwise or degenerate outline,
// a required point outside it, a required segment that segment_problem refuses, a target outside
// [2, 2'000'000], or an outline whose features are so far below the mesh size that a quality mesh needs
// more than max(4 × target, 4 × its points, 10 000) triangles (given up at that size, before it fills
// memory).
void mesh_outline(const MeshRequest& request, std::vector<Vec2>& rest, std::vector<Tri>& tri,
                  std::vector<int32_t>& required_vertex);

// The most triangles mesh_outline makes for a request of `target` triangles over `points` input points
// (outline vertices and required points): max(4 × target, 4 × points, 10 000).
int64_t max_mesh_triangles(int64_t target, int64_t points);

// A lower bound on the triangle count of any triangulation of the outline whose angles are all at least
// min_angle_deg: tan(min angle) P² / (36 A) for perimeter P and area A (each boundary edge e lies in a
// triangle of area ≥ tan(min angle) |e|² / 4, a triangle holds at most three of them, and Σ|e|² ≥ P² / n).
// A 0.3 m × 1e-7 m strip at 20 deg: 121 000.
double min_quality_triangles(const std::vector<Vec2>& outline, double min_angle_deg);

// A4, A5, A3, A6 as a rectangle at the origin (width = short side along u). Throws GeometryError on an
// unknown name.
std::vector<Vec2> preset_outline(const std::string& name);

// Validation used by mesh_outline and the scenario loader: empty string when the outline is a simple,
// counter-clockwise polygon with positive area and no repeated or collinear-degenerate vertices.
std::string outline_problem(const std::vector<Vec2>& outline);

// Empty when required segment k of the request can be constrained: two distinct required points, the
// segment inside the outline (it may run along it) and crossing no earlier segment; else the reason.
std::string segment_problem(const MeshRequest& request, size_t k);

bool point_in_polygon(const std::vector<Vec2>& polygon, const Vec2& p, double tolerance = 1e-12);

// The test mesh_outline puts a required point to, shared with the scenario loader so that a finger `check`
// accepts is one `run` meshes: inside the outline, or on it within 1e-10 of its bounding box's diagonal (a
// finger put on the edge from a decimal scenario file is rarely exactly on the line).
double outline_snap_distance(const std::vector<Vec2>& outline);
bool point_on_sheet(const std::vector<Vec2>& outline, const Vec2& p);

}  // namespace pt
