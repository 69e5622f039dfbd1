#include "systems/physics/grip.hpp"

#include "systems/physics/fingers.hpp"

#include <algorithm>

namespace pt {

Vec3 held_reaction(const Vertices& verts, const Vec3& gravity, int32_t vertex) {
  return -(verts.force[vertex] + verts.mass[vertex] * gravity);
}

Vec3 finger_reaction(const Vertices& verts, const Vec3& gravity, const Finger& finger) {
  Vec3 r = held_reaction(verts, gravity, finger.vertex);
  for (int32_t v : finger.pad) r += held_reaction(verts, gravity, v);
  return r;
}

bool check_grip(const Vertices& verts, const Vec3& gravity, std::vector<Finger>& fingers) {
  bool started = false;
  for (Finger& f : fingers) {
    if (f.vertex < 0 || f.slipping) continue;
    f.reaction = finger_reaction(verts, gravity, f);
    const double force = f.reaction.norm();
    if (force > f.grip) {
      f.slipping = true;
      f.slips += 1;
      started = true;
      f.reaction *= f.grip / force;
    }
    f.max_force = std::max(f.max_force, std::min(force, f.grip));
  }
  return started;
}

void read_reactions(const Vertices& verts, const Vec3& gravity, std::vector<Finger>& fingers) {
  for (Finger& f : fingers) {
    if (f.vertex < 0 || f.slipping) continue;
    f.reaction = finger_reaction(verts, gravity, f);
    f.max_force = std::max(f.max_force, std::min(f.reaction.norm(), f.grip));
  }
}

void read_transient_reactions(const Vertices& verts, const Vec3& gravity, std::vector<Finger>& fingers) {
  for (Finger& f : fingers)
    if (f.vertex >= 0 && !f.slipping) f.reaction = finger_reaction(verts, gravity, f);
}

bool grip_exceeded(const std::vector<Finger>& fingers) {
  for (const Finger& f : fingers)
    if (f.vertex >= 0 && !f.slipping && f.reaction.norm() > f.grip) return true;
  return false;
}

Vec3 slipping_pinch_force(const Vertices& verts, const Finger& finger, const Vec3& hold_point, double stiffness) {
  const Vec3 d = hold_point - verts.x[finger.vertex];
  const double n = d.norm();
  if (!(n > 0) || !(stiffness > 0)) return Vec3::Zero();
  return (std::min(stiffness * n, finger.grip) / n) * d;
}

void slipping_pinches(const Vertices& verts, const std::vector<Finger>& fingers, const std::vector<Vec3>& hold_point,
                      double stiffness, std::vector<ImplicitParams::Spring>& springs) {
  springs.clear();
  for (size_t i = 0; i < fingers.size(); ++i) {
    const Finger& f = fingers[i];
    if (f.vertex < 0 || !f.slipping) continue;
    const Vec3 force = slipping_pinch_force(verts, f, hold_point[i], stiffness);
    springs.push_back({f.vertex, verts.x[f.vertex] + force / stiffness, stiffness});
  }
}

bool regrip_slipping_fingers(const Vertices& verts, const std::vector<Vec3>& target_now,
                             const std::vector<Mat3>& rotation_now, std::vector<Finger>& fingers) {
  bool let_go = false;
  for (size_t i = 0; i < fingers.size(); ++i) {
    Finger& f = fingers[i];
    if (f.vertex < 0 || !f.slipping) continue;
    const Vec3 offset = verts.x[f.vertex] - target_now[i];
    f.slipping = false;
    if (offset.norm() > f.reach) {
      release(f);
      f.let_go = true;
      let_go = true;
    } else {
      f.hold_offset = offset;
      reset_pad_offsets(verts, rotation_now[i], f);
    }
  }
  return let_go;
}

}  // namespace pt
