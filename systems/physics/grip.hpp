// Fingers hold like fingers: a pinch is a hard positional constraint up to its grip force; beyond it the
// paper slides through the finger (docs/physics.md, "Fingers").
//
// A finger whose reaction exceeds its grip slips: the paper slides through the pinch, which then pulls
// it like a spring whose force is capped at the grip (sliding friction), integrated implicitly with the
// sheet (a pinch that dragged its vertex with a constant grip made a bang-bang force on one vertex's mass,
// which the time step could not follow). At the next frame, or after a cut, it holds the vertex again
// where the vertex is, so the offset between the finger and the material it holds is how far the paper
// has slid; once that offset exceeds the finger's reach the paper has slid out of the pinch and the
// finger lets go.
#pragma once

#include "components/sheet.hpp"
#include "systems/physics/integrate_implicit.hpp"

namespace pt {

// The force finger `f` applies to its held vertex in quasi-static balance: what the sheet's internal
// forces (`vertex_force`, membrane + bending) and gravity leave unbalanced there.
Vec3 held_reaction(const Vertices& verts, const Vec3& gravity, int32_t vertex);

// The force finger `finger` applies while it holds: held_reaction summed over its vertex and its pad.
Vec3 finger_reaction(const Vertices& verts, const Vec3& gravity, const Finger& finger);

// After a substep whose start state's internal forces are in verts.force: each holding finger's reaction;
// those beyond their grip start slipping (slips + 1). Returns true when one started. max_force records
// the force each finger applied: a pinch holds at most its grip, so a reading beyond it (the state in which
// the paper starts to slide) is recorded as the grip.
bool check_grip(const Vertices& verts, const Vec3& gravity, std::vector<Finger>& fingers);

// The reactions of the holding fingers (as check_grip reads them) without letting any slip.
void read_reactions(const Vertices& verts, const Vec3& gravity, std::vector<Finger>& fingers);

// The same reactions, not recorded in max_force: for a state the sheet does not move through (the one
// relaxation substep after a cut, whose lips are still springing open), which the tearing step reads but
// the fingers never hold.
void read_transient_reactions(const Vertices& verts, const Vec3& gravity, std::vector<Finger>& fingers);

// True when a holding finger's reaction exceeds its grip.
bool grip_exceeded(const std::vector<Finger>& fingers);

// The pinch of each slipping finger as a spring from its vertex towards its hold point (`hold_point[i]`,
// the finger's target plus its offset), of stiffness `stiffness`, its anchor no farther than grip /
// stiffness from the vertex so its force never exceeds the grip. Replaces `springs`.
void slipping_pinches(const Vertices& verts, const std::vector<Finger>& fingers, const std::vector<Vec3>& hold_point,
                      double stiffness, std::vector<ImplicitParams::Spring>& springs);

// The force a slipping finger's pinch applies now (as slipping_pinches sets it), N.
Vec3 slipping_pinch_force(const Vertices& verts, const Finger& finger, const Vec3& hold_point, double stiffness);

// At a frame's start, with `target_now[i]` finger i's target and `rotation_now[i]` its rotation: a
// slipping finger holds its vertex again where it is (hold_offset = x − target) and its pad where the paper
// lies (systems/physics/fingers.hpp), or lets go when that is farther than its reach. Returns true when a
// finger let go. A slipping finger's pad is not held: the paper slides through the whole pinch.
bool regrip_slipping_fingers(const Vertices& verts, const std::vector<Vec3>& target_now,
                             const std::vector<Mat3>& rotation_now, std::vector<Finger>& fingers);

}  // namespace pt
