#include "systems/physics/contact.hpp"

#include <algorithm>
#include <cmath>

namespace pt {

namespace {

// x on the plane through `on` with unit normal n, grown by nothing (the caller's surfaces are already grown
// by the offset): the normal velocity into the surface removed, the tangential one reduced by μ times it.
// The tangential position follows the filtered velocity: x = proj(x) + h (v_t' − v_t), so a vertex that
// sticks stays where the substep started it.
void push_out(const Vec3& n, const Vec3& on, double friction, double dt, Vec3& x, Vec3& v) {
  const double depth = n.dot(x - on);
  x -= depth * n;
  const double vn = v.dot(n);
  const double dvn = std::max(0.0, -vn);
  const Vec3 vt = v - vn * n;
  const double speed = vt.norm();
  const double stop = friction * dvn;
  const Vec3 vt_after = speed <= stop ? Vec3::Zero().eval() : ((1 - stop / speed) * vt).eval();
  x += dt * (vt_after - vt);
  v = vt_after + std::max(0.0, vn) * n;
  // x was moved along the surface only: a rounding below it is pulled back onto it.
  const double left = n.dot(x - on);
  if (left < 0) x -= left * n;
}

// The box [lo, hi] (already grown) against the step start → x: true when the step ends inside it or passes
// through it; `n` and `on` the face it entered (a start inside: the nearest face).
bool box_entry(const Vec3& lo, const Vec3& hi, const Vec3& start, const Vec3& x, Vec3& n, Vec3& on) {
  const Vec3 d = x - start;
  double enter = -INFINITY, leave = INFINITY;
  int axis = -1;
  double sign = 0;
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0) {
      if (!(start[a] > lo[a] && start[a] < hi[a])) return false;  // moves within a slab it is outside of
      continue;
    }
    double t0 = (lo[a] - start[a]) / d[a], t1 = (hi[a] - start[a]) / d[a];
    double face = d[a] > 0 ? -1 : 1;  // entering through lo when moving up the axis
    if (t0 > t1) std::swap(t0, t1);
    if (t0 > enter) enter = t0, axis = a, sign = face;
    leave = std::min(leave, t1);
  }
  if (!(enter < leave) || enter > 1 || leave <= 0) return false;
  if (enter >= 0 && axis >= 0) {
    n = Vec3::Zero();
    n[axis] = sign;
    on = sign < 0 ? lo : hi;
    return true;
  }
  // The start is inside (a finger let go of a vertex there, or rounding): out through the nearest face.
  if (!((x.array() > lo.array()).all() && (x.array() < hi.array()).all())) return false;
  double best = INFINITY;
  for (int a = 0; a < 3; ++a)
    for (const double s : {-1.0, 1.0}) {
      const double depth = s < 0 ? x[a] - lo[a] : hi[a] - x[a];
      if (depth < best) {
        best = depth;
        n = Vec3::Zero();
        n[a] = s;
        on = s < 0 ? lo : hi;
      }
    }
  return true;
}

bool resolve_one(const Obstacle& o, const ContactParams& p, const Vec3& start, Vec3& x, Vec3& v) {
  if (o.kind == Obstacle::Kind::Plane) {
    const Vec3 on = o.point + p.offset * o.normal;
    if (!(o.normal.dot(x - on) < 0)) return false;
    push_out(o.normal, on, o.friction, p.dt, x, v);
    return true;
  }
  const Vec3 grow = Vec3::Constant(p.offset);
  Vec3 n, on;
  if (!box_entry(o.min - grow, o.max + grow, start, x, n, on)) return false;
  push_out(n, on, o.friction, p.dt, x, v);
  return true;
}

}  // namespace

bool resolve_vertex_contact(const std::vector<Obstacle>& obstacles, const ContactParams& params, const Vec3& start,
                            Vec3& x, Vec3& v) {
  bool touched = false;
  // A vertex pushed out of one obstacle may be pushed into another (a box on the floor): a few sweeps.
  for (int sweep = 0; sweep < 4; ++sweep) {
    bool moved = false;
    for (const Obstacle& o : obstacles) moved |= resolve_one(o, params, start, x, v);
    touched |= moved;
    if (!moved) break;
  }
  return touched;
}

bool entered_surface(const std::vector<Obstacle>& obstacles, double offset, const Vec3& start, const Vec3& x,
                     Vec3& normal, Vec3& on, double& friction) {
  for (const Obstacle& o : obstacles) {
    if (o.kind == Obstacle::Kind::Plane) {
      on = o.point + offset * o.normal;
      if (!(o.normal.dot(x - on) < 0)) continue;
      normal = o.normal;
    } else {
      const Vec3 grow = Vec3::Constant(offset);
      if (!box_entry(o.min - grow, o.max + grow, start, x, normal, on)) continue;
    }
    friction = o.friction;
    return true;
  }
  return false;
}

bool resting_contact_normal(const Obstacle& o, double offset, double tolerance, const Vec3& x, Vec3& normal) {
  if (o.kind == Obstacle::Kind::Plane) {
    const double d = o.normal.dot(x - o.point) - offset;
    if (!(std::abs(d) <= tolerance)) return false;
    normal = o.normal;
    return true;
  }
  const Vec3 lo = o.min - Vec3::Constant(offset), hi = o.max + Vec3::Constant(offset);
  if (!((x.array() >= lo.array() - tolerance).all() && (x.array() <= hi.array() + tolerance).all())) return false;
  double best = INFINITY;
  for (int a = 0; a < 3; ++a)
    for (const double s : {-1.0, 1.0}) {
      const double gap = std::abs(s < 0 ? x[a] - lo[a] : hi[a] - x[a]);
      if (gap < best) {
        best = gap;
        normal = Vec3::Zero();
        normal[a] = s;
      }
    }
  return best <= tolerance;
}

double obstacle_distance(const Obstacle& o, const Vec3& p) {
  if (o.kind == Obstacle::Kind::Plane) return o.normal.dot(p - o.point);
  const Vec3 below = o.min - p, above = p - o.max;
  const Vec3 outside = below.cwiseMax(above);  // per axis: > 0 outside the slab
  if ((outside.array() < 0).all()) return outside.maxCoeff();
  return outside.cwiseMax(0.0).norm();
}

}  // namespace pt
