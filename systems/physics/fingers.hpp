// Finger targets at time t (docs/scenario-format.md, "fingers" / "hands"): a finger follows its own keys
// (linear in time, held before the first and after the last key), then its hand moves it rigidly: rotation
// about the hand's initial centroid, then translation, both interpolated between the hand's keys.
#pragma once

#include "components/sheet.hpp"

namespace pt {

// Position of a finger's own keys at time t (its start position when it has no keys).
Vec3 finger_key_position(const Finger& finger, double t);

// Rigid motion of a hand at time t applied to point q.
Vec3 apply_hand_motion(const Hand& hand, double t, const Vec3& q);

// Writes Finger::target of every finger for time t.
void update_finger_targets(double t, const std::vector<Hand>& hands, std::vector<Finger>& fingers);

}  // namespace pt
