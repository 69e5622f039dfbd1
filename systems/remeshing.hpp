// Cutting a tear segment into the coarse mesh in the pattern (paper §5.3 and appendix A, DESIGN §5.5).
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
CutResult cut_tear_segment(int32_t p, const Vec2& next, const Vec2& previous_direction, int32_t tear_id,
                           const RemeshParams& params, Sheet& sheet);

}  // namespace pt
