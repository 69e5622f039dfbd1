// Picking by ray casting against the current deformed sheet (issue 7): an Embree 3 scene over Vertices::x
// and Triangles::tri, rebuilt when the sheet's topology changes and refitted (vertex buffer update +
// rtcCommitScene) when only positions moved. A hit reports the triangle, the barycentric coordinates in
// Embree's convention (p = (1 − u − v) x0 + u x1 + v x2), the 3D point and the pattern point (the same
// barycentric combination of the rest positions), refined in double precision.
#pragma once

#include "components/sheet.hpp"

#include <cstdint>
#include <limits>
#include <memory>
#include <optional>

namespace pt {

struct PickHit {
  int32_t triangle = -1;
  double u = 0, v = 0;          // barycentric weights of corners 1 and 2 (corner 0: 1 − u − v)
  double t = 0;                 // ray parameter: point = origin + t · direction
  Vec3 point = Vec3::Zero();    // hit point on the deformed sheet, world m
  Vec2 uv = Vec2::Zero();       // the same point in the pattern, m
  Vec3 normal = Vec3::Zero();   // unit geometric normal of the deformed triangle (pattern CCW side)
};

class Picker {
 public:
  Picker();
  ~Picker();
  Picker(const Picker&) = delete;
  Picker& operator=(const Picker&) = delete;

  // Brings the scene up to date with `sheet`: full rebuild when topology_version or the array sizes
  // changed since the last call, otherwise vertex update and refit. The picker keeps its own copy of
  // the positions, pattern and triangles, so the sheet may change freely afterwards.
  void update(const Sheet& sheet);

  // Nearest hit along origin + t·direction, t in [tnear, tfar]; both sides of a triangle count.
  // Sees the sheet as it was at the last update().
  std::optional<PickHit> pick(const Vec3& origin, const Vec3& direction, double tnear = 0,
                              double tfar = std::numeric_limits<double>::infinity()) const;

  int64_t rebuilds() const;  // full rebuilds so far (tests, statistics)
  int64_t refits() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pt
