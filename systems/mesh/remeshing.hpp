// Cutting a tear segment into the coarse mesh in the pattern (paper §5.3 and appendix A;
// docs/tearing.md "The cut").
#pragma once

#include "components/sheet.hpp"

namespace pt {

struct RemeshParams {
  double split_angle = 0.1;     // rad: turning more than this at p keeps p as a corner of both lips
  double snap_fraction = 0.25;  // snap to an existing vertex closer than this fraction of the local edge
  double min_angle_deg = 5;     // never create a triangle with a smaller angle when a snap avoids it
};

struct CutResult {
  bool cut = false;              // false: nothing changed (segment degenerate or leaves at once)
  int32_t tip_vertex = -1;       // vertex at the new tip (−1 when the tear reached the boundary)
  bool reached_boundary = false; // the segment ended on the boundary: the tear ends there
  Vec2 end = Vec2::Zero();       // where the segment actually ended (after snapping), pattern
  int32_t new_vertices = 0;
  int32_t removed_vertices = 0;
};

// Cuts the segment from boundary vertex p towards `next` (pattern) for tear `tear_id`:
// crossed triangles are split so the segment lies on edges; vertices along it except the new tip are
// duplicated, one copy per lip (tagged Vertices::tear = tear_id); p is kept as a corner of both lips when
// the direction turns by more than split_angle relative to `previous_direction` (zero: always keep),
// otherwise removed from the lips. New vertices get 3D positions by barycentric interpolation and zero
// velocity. Vertex ids held by fingers and tips are remapped; tips are not added or removed here.
// Ends with refresh_after_topology_change. `next` is clipped at the first boundary crossing.
// Details (systems/mesh/remeshing.cpp):
//   - snapping: an edge crossing within snap_fraction of an edge's length from one of its ends goes through
//     that vertex; the end snaps to a corner closer than snap_fraction of the corner's shorter edge, or onto
//     an edge when very close to it (or when that avoids an angle below min_angle_deg). `end` is the result.
//     No edge is split within 1% of its length from an end: the cut goes to that vertex, or stops where it
//     stands when the vertex may not be snapped to (such slivers made the implicit solve refuse substeps).
//   - p is removed only when both lips come back along the same line (p was a tip between the two copies of
//     the previous tear vertex), no finger holds it, and both collapses keep every triangle CCW; removal
//     conserves the total pattern area exactly. A Tip whose vertex was p then points at the vertex p merged
//     into (the caller moves it to tip_vertex).
//   - flags: kNew is cleared everywhere and set on the vertices this cut created; kTip moves from p to the
//     new tip (none when the tear reached the boundary). Lip vertices (both copies) get Vertices::tear.
//   - cut == false leaves the sheet bit-identical (p not on the boundary, d outside the sheet or along its
//     boundary, degenerate segment).
CutResult cut_tear_segment(int32_t p, const Vec2& next, const Vec2& previous_direction, int32_t tear_id,
                           const RemeshParams& params, Sheet& sheet);

}  // namespace pt
