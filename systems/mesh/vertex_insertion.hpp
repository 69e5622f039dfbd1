// Inserting a vertex at a pattern point (a finger put on the sheet during a session, issue 7): the point
// becomes a mesh vertex, snapped to an existing vertex when one is close, else on an edge (2 → 4 or, on
// the boundary, 1 → 2 triangles) or inside a triangle (1 → 3). The deformed state is interpolated
// barycentrically, so the sheet does not move. Vertices are only appended: existing ids stay valid.
#pragma once

#include "components/sheet.hpp"

namespace pt {

struct InsertParams {
  double snap_fraction = 0.2;  // of the shortest edge of the containing triangle
};

// Returns the triangle containing pattern point uv (on its boundary counts), or −1.
int32_t find_pattern_triangle(const std::vector<Vec2>& rest, const std::vector<Tri>& tri, const Vec2& uv);

// Returns the vertex at uv (existing or new), −1 when uv is outside the sheet. Calls
// refresh_after_topology_change when it changed the mesh.
int32_t insert_pattern_vertex(const Vec2& uv, const InsertParams& params, Sheet& sheet);

}  // namespace pt
