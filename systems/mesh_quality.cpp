#include "systems/mesh_quality.hpp"

#include "systems/topology.hpp"

#include <algorithm>

namespace pt {

namespace {
double orient(const Vec2& a, const Vec2& b, const Vec2& c) {
  return (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
}
// > 0 when d lies inside the circumcircle of the counter-clockwise triangle (a, b, c).
double in_circle(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d) {
  const Vec2 ad = a - d, bd = b - d, cd = c - d;
  return (ad.squaredNorm() * (bd.x() * cd.y() - cd.x() * bd.y()) -
          bd.squaredNorm() * (ad.x() * cd.y() - cd.x() * ad.y()) +
          cd.squaredNorm() * (ad.x() * bd.y() - bd.x() * ad.y()));
}
}  // namespace

int32_t flip_towards_delaunay_near_new_vertices(const FlipParams& params, Sheet& sheet) {
  const Vertices& V = sheet.verts;
  Triangles& T = sheet.tris;
  const int32_t nt = T.size();
  // Triangles allowed to change: rings around the new vertices.
  std::vector<char> active(nt, 0);
  for (int32_t t = 0; t < nt; ++t)
    for (int32_t c : T.tri[t])
      if (V.flags[c] & kNew) active[t] = 1;
  for (int32_t r = 1; r < params.rings; ++r) {
    std::vector<char> grown = active;
    for (int32_t t = 0; t < nt; ++t)
      if (active[t])
        for (int32_t o : sheet.topo.neighbor[t])
          if (o >= 0) grown[o] = 1;
    active.swap(grown);
  }
  int32_t flips = 0;
  bool any = true;
  while (any && flips < params.max_flips) {
    any = false;
    // Neighbours are rebuilt between passes; within a pass each triangle flips at most once, so the
    // neighbour table read in the pass stays valid for the triangles not yet touched.
    std::vector<char> touched(nt, 0);
    for (int32_t t = 0; t < nt && flips < params.max_flips; ++t) {
      if (!active[t] || touched[t]) continue;
      for (int32_t i = 0; i < 3; ++i) {
        const int32_t o = sheet.topo.neighbor[t][i];
        if (o < 0 || !active[o] || touched[o]) continue;
        const int32_t a = T.tri[t][i], b = T.tri[t][(i + 1) % 3], c = T.tri[t][(i + 2) % 3];
        int32_t k = 0;
        while (k < 3 && !(T.tri[o][k] == b && T.tri[o][(k + 1) % 3] == a)) ++k;
        if (k == 3) continue;
        const int32_t d = T.tri[o][(k + 2) % 3];
        const Vec2 &pa = V.rest[a], &pb = V.rest[b], &pc = V.rest[c], &pd = V.rest[d];
        const double scale = std::max({(pa - pb).squaredNorm(), (pc - pd).squaredNorm()});
        if (in_circle(pa, pb, pc, pd) <= 1e-12 * scale * scale) continue;
        // The flipped pair (a, d, c), (d, b, c) must stay counter-clockwise (the quad is convex).
        if (orient(pa, pd, pc) <= 1e-14 * scale || orient(pd, pb, pc) <= 1e-14 * scale) continue;
        T.tri[t] = {a, d, c};
        T.tri[o] = {d, b, c};
        touched[t] = touched[o] = 1;
        ++flips;
        any = true;
        break;
      }
    }
    if (any) {
      std::vector<int32_t> piece;
      build_topology(T.tri, V.size(), sheet.topo, T.piece);
    }
  }
  if (flips > 0) refresh_after_topology_change(sheet);
  return flips;
}

}  // namespace pt
