// Fingers hold like fingers: a pinch is a hard positional constraint up to its grip force; beyond it the
// paper slides through the finger (docs/physics.md, "Fingers").
//
// A finger whose reaction exceeds its grip starts slipping: it no longer prescribes its vertex but drags
// it with the grip force towards its hold point (sliding friction at the grip), for the rest of the frame.
// At the next frame it holds the vertex again where the vertex is, so the offset between the finger and
// the material it holds is how far the paper has slid; once that offset exceeds the finger's reach the
// paper has slid out of the pinch and the finger lets go.
#pragma once

#include "components/sheet.hpp"

namespace pt {

// The force finger `f` applies to its held vertex in quasi-static balance: what the sheet's internal
// forces (`vertex_force`, membrane + bending) and gravity leave unbalanced there.
Vec3 held_reaction(const Vertices& verts, const Vec3& gravity, int32_t vertex);

// After a substep whose start state's internal forces are in verts.force: each holding finger's reaction;
// those beyond their grip start slipping (slips + 1). Returns true when one started. A slipping finger's
// reaction is its drag. max_force records the force each finger applied: a finger at its grip slides, so
// a reading beyond it is recorded as the grip.
bool check_grip(const Vertices& verts, const Vec3& gravity, std::vector<Finger>& fingers);

// The drag of each slipping finger on its vertex: the grip along the direction from the vertex to the
// finger's hold point (`hold_point[i]`, the finger's target plus its offset), into `external` (sized to
// the vertices and zeroed when any finger slips; left empty when none does).
void slipping_drag(const Vertices& verts, const std::vector<Finger>& fingers, const std::vector<Vec3>& hold_point,
                   std::vector<Vec3>& external);

// At a frame's start, with `target_now[i]` finger i's target: a slipping finger holds its vertex again
// where it is (hold_offset = x − target), or lets go when that is farther than its reach. Returns true
// when a finger let go.
bool regrip_slipping_fingers(const Vertices& verts, const std::vector<Vec3>& target_now, std::vector<Finger>& fingers);

}  // namespace pt
