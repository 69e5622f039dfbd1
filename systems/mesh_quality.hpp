// Local mesh quality after a remesh (paper §5.3 keeps the mesh coarse; this keeps it well shaped):
// Lawson edge flips towards the Delaunay triangulation of the pattern, restricted to the triangles
// around vertices the last cut created (kNew). Cutting a segment splits the triangles it crosses and
// inserts its end point 1 → 3, which leaves fans of slivers along the tear; slivers make the membrane
// forces that clustering reads (paper §5.1) depend on the mesh. Boundary edges (outline and lips) are
// never flipped, vertex ids never change, and the pattern area is unchanged.
#pragma once

#include "components/sheet.hpp"

namespace pt {

struct FlipParams {
  int32_t max_flips = 200;  // per call
  int32_t rings = 2;        // triangles within this many edge rings of a kNew vertex may flip
};

// Returns the number of flips. Calls refresh_after_topology_change when it flipped anything.
int32_t flip_towards_delaunay_near_new_vertices(const FlipParams& params, Sheet& sheet);

}  // namespace pt
