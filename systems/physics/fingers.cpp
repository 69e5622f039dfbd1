#include "systems/physics/fingers.hpp"

#include "systems/common/pattern_geometry.hpp"

#include <Eigen/Geometry>

#include <algorithm>

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

namespace {

// A hand's keys interpolated at time t (held before the first and after the last).
struct HandPose {
  Vec3 translate = Vec3::Zero();
  double angle_deg = 0;
  Vec3 axis = Vec3(0, 0, 1);
};

HandPose hand_pose(const Hand& hand, double t) {
  const auto& k = hand.keys;
  if (t <= k.front().t) return {k.front().translate, k.front().rotate_deg, k.front().axis};
  if (t >= k.back().t) return {k.back().translate, k.back().rotate_deg, k.back().axis};
  size_t i = 1;
  while (i < k.size() && t >= k[i].t) ++i;
  const double span = k[i].t - k[i - 1].t;
  const double a = span > 0 ? (t - k[i - 1].t) / span : 1.0;
  // The axis of the key being moved towards: a hand turns about one axis per interval.
  return {(1 - a) * k[i - 1].translate + a * k[i].translate, (1 - a) * k[i - 1].rotate_deg + a * k[i].rotate_deg,
          k[i].axis};
}

Mat3 rotation_of(const HandPose& pose) {
  // The norm of [1e200, 1e200, 0] overflows and that of [1e-200, 0, 0] underflows, either of which would
  // make the axis zero and the rotation a scaling: such an axis is scaled by its largest component first
  // (others keep the plain quotient, so their results do not change by a rounding).
  const Vec3& axis = pose.axis;
  const double n = axis.norm();
  const double largest = axis.cwiseAbs().maxCoeff();
  Vec3 unit_axis(0, 0, 1);
  if (std::isfinite(n) && n >= 1e-150)
    unit_axis = axis / n;
  else if (largest > 0 && std::isfinite(largest))
    unit_axis = (axis / largest).normalized();
  return Eigen::AngleAxisd(pose.angle_deg * std::numbers::pi / 180.0, unit_axis).toRotationMatrix();
}

}  // namespace

Mat3 hand_rotation(const Hand& hand, double t) {
  return hand.keys.empty() ? Mat3::Identity() : rotation_of(hand_pose(hand, t));
}

Vec3 apply_hand_motion(const Hand& hand, double t, const Vec3& q) {
  if (hand.keys.empty()) return q;
  const HandPose pose = hand_pose(hand, t);
  return hand.centroid + rotation_of(pose) * (q - hand.centroid) + pose.translate;
}

Mat3 finger_rotation(const std::vector<Hand>& hands, const Finger& f, double t) {
  return f.hand >= 0 ? hand_rotation(hands[f.hand], t) : Mat3::Identity();
}

void reset_pad_offsets(const Vertices& verts, const Mat3& rotation, Finger& f) {
  f.pad_offset.clear();
  for (int32_t v : f.pad) f.pad_offset.push_back(rotation.transpose() * (verts.x[v] - verts.x[f.vertex]));
}

void grab_pad(const Vertices& verts, const std::vector<Hand>& hands, double t, size_t i, std::vector<Finger>& fingers) {
  Finger& f = fingers[i];
  f.pad.clear();
  f.pad_offset.clear();
  if (f.vertex < 0 || !(f.pad_radius > 0)) return;
  // The ring the builder meshed lies at the radius exactly: a relative margin keeps it in.
  const double reach2 = f.pad_radius * f.pad_radius * (1 + 1e-9);
  for (int32_t v = 0; v < static_cast<int32_t>(verts.rest.size()); ++v) {
    if (v == f.vertex || (verts.rest[v] - f.uv).squaredNorm() > reach2) continue;
    bool taken = false;
    for (size_t k = 0; k < fingers.size() && !taken; ++k) {
      if (k == i || fingers[k].vertex < 0) continue;
      taken = fingers[k].vertex == v ||
              std::find(fingers[k].pad.begin(), fingers[k].pad.end(), v) != fingers[k].pad.end();
    }
    if (!taken) f.pad.push_back(v);
  }
  reset_pad_offsets(verts, finger_rotation(hands, f, t), f);
}

void release(Finger& f) {
  f.vertex = -1;
  f.released = true;
  f.reaction.setZero();
  f.pad.clear();
  f.pad_offset.clear();
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

namespace {

// Distance from p to the triangle abc (0 inside), pattern.
double distance_to_triangle(const Vec2& p, const Vec2& a, const Vec2& b, const Vec2& c) {
  const double s0 = cross(b - a, p - a), s1 = cross(c - b, p - b), s2 = cross(a - c, p - c);
  if ((s0 >= 0 && s1 >= 0 && s2 >= 0) || (s0 <= 0 && s1 <= 0 && s2 <= 0)) return 0;
  return std::sqrt(std::min({point_segment_distance2(p, a, b), point_segment_distance2(p, b, c),
                             point_segment_distance2(p, c, a)}));
}

// Signed area of the intersection of the disc of radius r about the origin with the triangle (0, a, b):
// the sector of the disc where the segment ab lies outside it, the triangle where inside.
double disc_wedge_area(const Vec2& a, const Vec2& b, double r) {
  auto sector = [&](const Vec2& u, const Vec2& v) { return 0.5 * r * r * std::atan2(cross(u, v), u.dot(v)); };
  const Vec2 d = b - a;
  const double qa = d.squaredNorm(), qb = a.dot(d), qc = a.squaredNorm() - r * r;
  const double discriminant = qb * qb - qa * qc;
  if (!(qa > 0) || discriminant <= 0) return sector(a, b);  // the line misses the disc
  const double root = std::sqrt(discriminant);
  const double t1 = (-qb - root) / qa, t2 = (-qb + root) / qa;  // where the line crosses the circle
  if (t2 <= 0 || t1 >= 1) return sector(a, b);                  // the segment is outside
  const Vec2 p1 = a + std::max(t1, 0.0) * d, p2 = a + std::min(t2, 1.0) * d;
  return sector(a, p1) + 0.5 * cross(p1, p2) + sector(p2, b);
}

// The fraction of triangle abc's area within r of p, exactly: the wedges of its three edges seen from p.
double fraction_within(const Vec2& p, double r, const Vec2& a, const Vec2& b, const Vec2& c) {
  const double area = 0.5 * cross(b - a, c - a);
  if (area == 0) return 0;
  const double inside =
      disc_wedge_area(a - p, b - p, r) + disc_wedge_area(b - p, c - p, r) + disc_wedge_area(c - p, a - p, r);
  return std::clamp(inside / area, 0.0, 1.0);
}

}  // namespace

void mark_pinched_triangles(const std::vector<Finger>& fingers, const std::vector<Vec2>& rest,
                            const std::vector<Tri>& tri, const Topology& topo, double fingertip_radius,
                            std::vector<double>& pinched) {
  const int32_t nt = static_cast<int32_t>(tri.size());
  pinched.assign(nt, 0.0);
  std::vector<int32_t> visited, stack;
  for (const Finger& f : fingers) {
    if (f.vertex < 0 || f.vertex >= topo.vertex_count()) continue;
    const Vec2 centre = rest[f.vertex];
    const double r = std::max(fingertip_radius, f.pad_radius);
    visited.clear();
    stack.clear();
    for (const int32_t t : topo.fan(f.vertex)) stack.push_back(t);
    while (!stack.empty()) {
      const int32_t t = stack.back();
      stack.pop_back();
      if (t < 0 || t >= nt || std::find(visited.begin(), visited.end(), t) != visited.end()) continue;
      visited.push_back(t);
      const Vec2 &a = rest[tri[t][0]], &b = rest[tri[t][1]], &c = rest[tri[t][2]];
      if (distance_to_triangle(centre, a, b, c) >= r) continue;
      pinched[t] = std::max(pinched[t], fraction_within(centre, r, a, b, c));
      for (const int32_t n : topo.neighbor[t]) stack.push_back(n);
    }
  }
}

}  // namespace pt
