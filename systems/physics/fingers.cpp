#include "systems/physics/fingers.hpp"

#include "systems/common/pattern_geometry.hpp"

#include <Eigen/Geometry>

#include <algorithm>

#include <cmath>
#include <numbers>

namespace pt {

namespace {

template <int N>
using KeyValue = Eigen::Matrix<double, N, 1>;

// The slope (per second) of "smooth" keys at key j, each component on its own: zero at the first and last
// key (the motion starts and ends at rest) and where the keys turn back or hold (a local extremum stays
// one); elsewhere the weighted harmonic mean of the two secants (Fritsch & Butland 1984, as in pchip),
// which keeps each interval monotone, so the curve never leaves the range of its two keys.
template <int N, class Time, class Value>
KeyValue<N> smooth_key_slope(size_t count, const Time& time, const Value& value, size_t j) {
  KeyValue<N> slope = KeyValue<N>::Zero();
  if (j == 0 || j + 1 >= count) return slope;
  const double h0 = time(j) - time(j - 1), h1 = time(j + 1) - time(j);
  if (!(h0 > 0) || !(h1 > 0)) return slope;
  const KeyValue<N> d0 = (value(j) - value(j - 1)) / h0, d1 = (value(j + 1) - value(j)) / h1;
  for (int c = 0; c < N; ++c)
    if (d0[c] * d1[c] > 0) slope[c] = 3 * (h0 + h1) / ((2 * h1 + h0) / d0[c] + (h1 + 2 * h0) / d1[c]);
  return slope;
}

// Keys (time(k), value(k)), 0 < count, joined at time t and held before the first and after the last;
// *interval, if asked, is the key being moved towards (the first before it, the last after it).
// "linear": constant speed from key to key. "smooth": the cubic Hermite curve through the keys with the
// slopes above: its velocity is continuous, so a hand neither starts, stops nor turns at once (an
// instant stop of a moving hand jerks the paper it holds: the sheet's momentum lands on the fingers).
template <int N, class Time, class Value>
KeyValue<N> interpolate_keys(size_t count, const Time& time, const Value& value, KeyInterpolation how, double t,
                             size_t* interval = nullptr) {
  size_t i = 1;
  while (i < count && t >= time(i)) ++i;
  if (interval) *interval = t <= time(0) ? 0 : std::min(i, count - 1);
  if (t <= time(0)) return value(0);
  if (i == count) return value(count - 1);
  const double span = time(i) - time(i - 1);
  const double a = span > 0 ? (t - time(i - 1)) / span : 1.0;
  if (how == KeyInterpolation::linear || !(span > 0)) return (1 - a) * value(i - 1) + a * value(i);
  const KeyValue<N> m0 = smooth_key_slope<N>(count, time, value, i - 1);
  const KeyValue<N> m1 = smooth_key_slope<N>(count, time, value, i);
  const double a2 = a * a, a3 = a2 * a;
  // The Hermite basis written from the first key, so that two equal keys hold exactly.
  return value(i - 1) + (3 * a2 - 2 * a3) * (value(i) - value(i - 1)) + span * ((a3 - 2 * a2 + a) * m0 + (a3 - a2) * m1);
}

}  // namespace

bool key_interpolation_from_name(std::string_view name, KeyInterpolation& out) {
  if (name == "linear") out = KeyInterpolation::linear;
  else if (name == "smooth") out = KeyInterpolation::smooth;
  else return false;
  return true;
}

const char* key_interpolation_name(KeyInterpolation how) {
  return how == KeyInterpolation::smooth ? "smooth" : "linear";
}

Vec3 finger_key_position(const Finger& finger, double t) {
  const auto& k = finger.keys;
  if (k.empty()) return finger.start;
  return interpolate_keys<3>(
      k.size(), [&](size_t j) { return k[j].t; }, [&](size_t j) { return k[j].position; }, finger.interpolation, t);
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
  // The translation and the angle, joined as one 4-vector (each component on its own).
  const auto pose = [&](size_t j) {
    KeyValue<4> v;
    v << k[j].translate, k[j].rotate_deg;
    return v;
  };
  size_t towards = 0;
  const KeyValue<4> v =
      interpolate_keys<4>(k.size(), [&](size_t j) { return k[j].t; }, pose, hand.interpolation, t, &towards);
  // The axis of the key being moved towards: a hand turns about one axis per interval.
  return {v.head<3>(), v[3], k[towards].axis};
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
      if (point_triangle_distance(centre, a, b, c) >= r) continue;
      pinched[t] = std::max(pinched[t], fraction_within(centre, r, a, b, c));
      for (const int32_t n : topo.neighbor[t]) stack.push_back(n);
    }
  }
}

}  // namespace pt
