// Finger targets at time t (docs/scenario-format.md, "fingers" / "hands"): a finger follows its own keys
// (joined as its "interpolation" says, held before the first and after the last key), then its hand moves it rigidly: rotation
// about the centroid of where the hand's fingers hold (hand_centroid_of_starts), then translation, both interpolated between the hand's keys.
#pragma once

#include "components/sheet.hpp"

#include <string_view>

namespace pt {

// The interpolation called `name` ("linear" or "smooth"); false, out unchanged, for another name.
bool key_interpolation_from_name(std::string_view name, KeyInterpolation& out);
const char* key_interpolation_name(KeyInterpolation how);

// Position of a finger's own keys at time t (its start position when it has no keys).
Vec3 finger_key_position(const Finger& finger, double t);

// Rigid motion of a hand at time t applied to point q.
Vec3 apply_hand_motion(const Hand& hand, double t, const Vec3& q);

// The rotation part of that motion (the identity for a hand without keys).
Mat3 hand_rotation(const Hand& hand, double t);

// The rotation finger f turns with at time t: its hand's, or the identity for a finger in no hand.
Mat3 finger_rotation(const std::vector<Hand>& hands, const Finger& f, double t);

// Pads. A pinch holds a patch of paper between thumb and finger, not a point: a hand that turns about the
// line through its two fingers turns those patches, and so the sheet, where a point would turn nothing
// (only the triangles locked across that line would carry the turn; docs/physics.md, "Fingers"). A finger
// with pad_radius > 0 holds, besides its vertex, every vertex within pad_radius of its point in the pattern
// that no other finger holds, each kept at its offset from the finger's vertex as the hand turns:
//   target_j = target + hold_offset + R(t) pad_offset[j].
// The sheet builder meshes a ring of points at pad_radius around the finger, so every mesh resolves the
// same disc.

// Finger i takes its pad on the sheet as it is now (time t): the vertices within its pad_radius of its
// point (rest positions) held by no other finger, their offsets those of the current positions.
void grab_pad(const Vertices& verts, const std::vector<Hand>& hands, double t, size_t i, std::vector<Finger>& fingers);

// The offsets of f's pad taken again from the current positions, with `rotation` the finger's now (a
// pinch that holds again where the paper slid to).
void reset_pad_offsets(const Vertices& verts, const Mat3& rotation, Finger& f);


// The hand's centroid, about which it turns: the mean start of its fingers (where each was put, or, for a
// finger put on later, where it grabbed the sheet). The sheet builder and each later grab call it.
void hand_centroid_of_starts(const std::vector<Finger>& fingers, Hand& hand);

// The finger lets go of the sheet: it holds no vertex and no pad, and applies no force.
void release(Finger& f);

// Writes Finger::target of every finger for time t.
void update_finger_targets(double t, const std::vector<Hand>& hands, std::vector<Finger>& fingers);

// The radius of the paper a fingertip presses flat in a pinch (a finger's pad, when larger, counts
// instead): there the paper cannot wrinkle and carries compression (Triangles::pinched).
constexpr double kFingertipRadius = 0.005;  // m

// Triangles::pinched: for every triangle, the fraction of its area between a finger's tips, the disc of
// radius max(fingertip_radius, pad radius) about the finger's vertex in the pattern (slipping or not: the
// paper slides between them); 0 elsewhere. A finger's fan is always visited, and the triangles beyond it
// while they come within the disc. `pinched` is rewritten with tri.size() entries; topo must be current.
void mark_pinched_triangles(const std::vector<Finger>& fingers, const std::vector<Vec2>& rest,
                            const std::vector<Tri>& tri, const Topology& topo, double fingertip_radius,
                            std::vector<double>& pinched);

}  // namespace pt
