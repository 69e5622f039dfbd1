#include "systems/physics/fingers.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <numbers>

namespace pt {

Vec3 finger_key_position(const Finger& finger, double t) {
  const auto& k = finger.keys;
  if (k.empty()) return finger.start;
  if (t <= k.front().t) return k.front().position;
  if (t >= k.back().t) return k.back().position;
  for (size_t i = 1; i < k.size(); ++i)
    if (t < k[i].t) {
      const double span = k[i].t - k[i - 1].t;
      const double a = span > 0 ? (t - k[i - 1].t) / span : 1.0;
      return (1 - a) * k[i - 1].position + a * k[i].position;
    }
  return k.back().position;
}

Vec3 apply_hand_motion(const Hand& hand, double t, const Vec3& q) {
  const auto& k = hand.keys;
  if (k.empty()) return q;
  Vec3 translate;
  double angle_deg;
  Vec3 axis;
  if (t <= k.front().t) {
    translate = k.front().translate, angle_deg = k.front().rotate_deg, axis = k.front().axis;
  } else if (t >= k.back().t) {
    translate = k.back().translate, angle_deg = k.back().rotate_deg, axis = k.back().axis;
  } else {
    size_t i = 1;
    while (i < k.size() && t >= k[i].t) ++i;
    const double span = k[i].t - k[i - 1].t;
    const double a = span > 0 ? (t - k[i - 1].t) / span : 1.0;
    translate = (1 - a) * k[i - 1].translate + a * k[i].translate;
    angle_deg = (1 - a) * k[i - 1].rotate_deg + a * k[i].rotate_deg;
    // The axis of the key being moved towards: a hand turns about one axis per interval.
    axis = k[i].axis;
  }
  // The norm of [1e200, 1e200, 0] overflows and that of [1e-200, 0, 0] underflows, either of which would
  // make the axis zero and the rotation a scaling: such an axis is scaled by its largest component first
  // (others keep the plain quotient, so their results do not change by a rounding).
  const double n = axis.norm();
  const double largest = axis.cwiseAbs().maxCoeff();
  Vec3 unit_axis(0, 0, 1);
  if (std::isfinite(n) && n >= 1e-150)
    unit_axis = axis / n;
  else if (largest > 0 && std::isfinite(largest))
    unit_axis = (axis / largest).normalized();
  const Eigen::AngleAxisd rotation(angle_deg * std::numbers::pi / 180.0, unit_axis);
  return hand.centroid + rotation * (q - hand.centroid) + translate;
}

void hand_centroid_of_starts(const std::vector<Finger>& fingers, Hand& hand) {
  Vec3 c = Vec3::Zero();
  for (int32_t i : hand.fingers) c += fingers[i].start;
  if (!hand.fingers.empty()) c /= static_cast<double>(hand.fingers.size());
  hand.centroid = c;
}

void update_finger_targets(double t, const std::vector<Hand>& hands, std::vector<Finger>& fingers) {
  for (Finger& f : fingers) {
    Vec3 p = finger_key_position(f, t);
    if (f.hand >= 0) p = apply_hand_motion(hands[f.hand], t, p);
    f.target = p;
  }
}

}  // namespace pt
