// Small 2D geometry of the pattern shared by systems (meshing, carving, the patch relaxation).
#pragma once

#include "components/sheet.hpp"

#include <algorithm>
#include <cmath>

namespace pt {

// The z component of the cross product of two pattern vectors: > 0 when b is counter-clockwise of a.
inline double cross(const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); }

// Squared distance from p to the segment [a, b] (a point when a = b); `t_out`, if given, receives the
// parameter in [0, 1] of the closest point a + t (b − a).
inline double point_segment_distance2(const Vec2& p, const Vec2& a, const Vec2& b, double* t_out = nullptr) {
  const Vec2 ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  if (t_out) *t_out = t;
  return (p - (a + t * ab)).squaredNorm();
}

// Distance from p to the triangle abc (0 inside), pattern.
inline double point_triangle_distance(const Vec2& p, const Vec2& a, const Vec2& b, const Vec2& c) {
  const double s0 = cross(b - a, p - a), s1 = cross(c - b, p - b), s2 = cross(a - c, p - c);
  if ((s0 >= 0 && s1 >= 0 && s2 >= 0) || (s0 <= 0 && s1 <= 0 && s2 <= 0)) return 0;
  return std::sqrt(std::min({point_segment_distance2(p, a, b), point_segment_distance2(p, b, c),
                             point_segment_distance2(p, c, a)}));
}

}  // namespace pt
