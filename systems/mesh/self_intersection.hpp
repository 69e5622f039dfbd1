// How many pairs of the sheet's triangles intersect each other (a measure of self-contact failures, issue
// 25): pairs that share no vertex, tested exactly (CGAL's exact predicates on the double coordinates,
// Epick's Do_intersect_3 for two triangles), after a broad phase of their bounding boxes
// (CGAL::box_intersection_d). Pairs sharing a vertex id are adjacent in the mesh and excluded; so are
// pairs with two coincident corners (a tear's duplicated vertex at its tip, the same point under two ids),
// which touch by construction. Degenerate triangles (collinear corners) are skipped.
#pragma once

#include "components/sheet.hpp"

#include <vector>

namespace pt {

struct SelfIntersectionCount {
  int64_t intersecting = 0;  // non-adjacent pairs that intersect (touching counts)
  int64_t candidates = 0;    // non-adjacent pairs whose boxes overlap (the exact test's work)
  int64_t degenerate = 0;    // triangles skipped
};

SelfIntersectionCount count_self_intersections(const std::vector<Vec3>& x, const std::vector<Tri>& tris);

}  // namespace pt
