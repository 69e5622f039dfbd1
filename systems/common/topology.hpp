// Topology and rest data derived from the triangle list: the vertex→triangle fans, triangle neighbours,
// hinges for bending, boundary loops, pieces, boundary and inward-angle flags, lumped masses.
// Every system that changes triangles calls `refresh_after_topology_change` once at the end.
#pragma once

#include "components/sheet.hpp"

#include <string>

namespace pt {

// Inverse rest matrix and pattern area of every triangle (Triangles::rest_inv, rest_area).
void update_rest_data(const std::vector<Vec2>& rest, const std::vector<Tri>& tri,
                      std::vector<Mat2>& rest_inv, std::vector<double>& rest_area);

// Lumped masses: each triangle gives a third of density · thickness · area to each corner.
void lump_masses(const std::vector<Tri>& tri, const std::vector<double>& rest_area,
                 const Material& material, std::vector<double>& mass);

// Spare entries given to each vertex fan by build_topology: a cut's edge split adds one triangle to a fan
// (its lip duplicates take triangles away), so most fans it changes are rewritten in place.
constexpr int32_t kFanSlack = 2;

// Fans, neighbours, hinges, boundary next/prev and connected pieces (written to `piece`, numbered in
// order of their lowest triangle so the numbering does not depend on anything but the triangle list).
void build_topology(const std::vector<Tri>& tri, int32_t vertex_count, Topology& topo,
                    std::vector<int32_t>& piece);

// Interior angle of the sheet at boundary vertex v, in the pattern, in (0, 2π); 0 for interior vertices.
double interior_pattern_angle(const Topology& topo, const std::vector<Vec2>& rest, int32_t v);

// kBoundary and kInward (interior angle > π + inward_tolerance) from the topology; other bits kept.
void update_boundary_flags(const Topology& topo, const std::vector<Vec2>& rest, double inward_tolerance,
                           std::vector<uint8_t>& flags);

// All of the above, plus topology_version bump. Call after meshing or any remesh.
void refresh_after_topology_change(Sheet& sheet);

// What a local remesh changed, in the ids after its compaction (the triangle and vertex arrays are already
// in their final state; sheet.topo still describes the sheet before the change).
struct LocalTopologyChange {
  std::vector<int32_t> triangles;  // every triangle modified, appended, moved or renamed (ascending, unique)
  std::vector<int32_t> vertices;   // every corner of those, before and after the change (ascending, unique)
  std::vector<std::pair<int32_t, int32_t>> moved_triangles;  // (id before, id after) of moved survivors
  std::vector<int32_t> dead_triangles;  // ids before the change of the triangles that were removed
  bool pieces_may_split = false;   // a tear reached the boundary: the sheet may have parted
};

// The same topology as refresh_after_topology_change (fans, neighbours, boundary links, pieces, rest data,
// masses and flags bit for bit; the same hinges, in another order, see Topology::hinges), in time that
// grows with the size of the change: a cut rewrites a handful of triangles, and rebuilding every fan, hinge
// and flag after each one made the cut linear in the sheet (issue 3: the tearing step's cost grows with the
// local mesh size). Only two things still visit the whole sheet: a cut that reaches the boundary floods the
// pieces again (the sheet may have parted), and once a sheet has several pieces their numbering is checked.
// Falls back to the full refresh when sheet.topo is not the topology of the sheet before the change.
void refresh_after_local_change(const LocalTopologyChange& change, Sheet& sheet);

// Lays the fans out again without the entries that moved fans left behind (Topology::vt_unused); fan order and
// contents unchanged. The local refresh calls it once they reach half of the pool.
void compact_fans(Topology& topo);

// The invariants of docs/architecture.md "Data and its invariants". Returns an empty string when they hold,
// else a description of the first violation. `expected_area` < 0 skips the area check.
std::string check_mesh_invariants(const Sheet& sheet, double expected_area = -1);

// "" when every position, velocity, rest point, finger target and reaction, tear tip and detail point is
// finite, else what the first one that is not belongs to ("vertex 12", "finger A", "tear tip").
std::string first_non_finite(const Sheet& sheet);

double total_rest_area(const Triangles& tris);

}  // namespace pt
