// Finger targets at time t (docs/scenario-format.md, "fingers" / "hands"): a finger follows its own keys
// (linear in time, held before the first and after the last key), then its hand moves it rigidly: rotation
// about the centroid of where the hand's fingers hold (hand_centroid_of_starts), then translation, both interpolated between the hand's keys.
#pragma once

#include "components/sheet.hpp"

namespace pt {

// Position of a finger's own keys at time t (its start position when it has no keys).
Vec3 finger_key_position(const Finger& finger, double t);

// Rigid motion of a hand at time t applied to point q.
Vec3 apply_hand_motion(const Hand& hand, double t, const Vec3& q);

// The hand's centroid, about which it turns: the mean start of its fingers (where each was put, or, for a
// finger put on later, where it grabbed the sheet). The sheet builder and each later grab call it.
void hand_centroid_of_starts(const std::vector<Finger>& fingers, Hand& hand);

// Writes Finger::target of every finger for time t.
void update_finger_targets(double t, const std::vector<Hand>& hands, std::vector<Finger>& fingers);

}  // namespace pt
