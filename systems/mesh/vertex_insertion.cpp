#include "systems/mesh/vertex_insertion.hpp"

#include "systems/common/topology.hpp"

#include <algorithm>
#include <cmath>

namespace pt {

namespace {
double cross2(const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); }

Vec3 barycentric(const std::vector<Vec2>& rest, const Tri& t, const Vec2& p) {
  const Vec2 a = rest[t[0]], b = rest[t[1]], c = rest[t[2]];
  const double area = cross2(b - a, c - a);
  const double l1 = cross2(p - a, c - a) / area;
  const double l2 = cross2(b - a, p - a) / area;
  return Vec3(1 - l1 - l2, l1, l2);
}
}  // namespace

int32_t find_pattern_triangle(const std::vector<Vec2>& rest, const std::vector<Tri>& tri, const Vec2& uv) {
  int32_t best = -1;
  double best_min = -1e300;
  for (int32_t t = 0; t < static_cast<int32_t>(tri.size()); ++t) {
    const Vec3 l = barycentric(rest, tri[t], uv);
    const double m = l.minCoeff();
    if (m > best_min) {
      best_min = m;
      best = t;
    }
  }
  // Accept points on an edge up to rounding.
  return best_min >= -1e-9 ? best : -1;
}

int32_t insert_pattern_vertex(const Vec2& uv, const InsertParams& params, Sheet& sheet) {
  Vertices& V = sheet.verts;
  Triangles& T = sheet.tris;
  const int32_t t = find_pattern_triangle(V.rest, T.tri, uv);
  if (t < 0) return -1;
  const Tri tri = T.tri[t];
  double shortest = 1e300;
  for (int i = 0; i < 3; ++i) shortest = std::min(shortest, (V.rest[tri[i]] - V.rest[tri[(i + 1) % 3]]).norm());
  const double snap = params.snap_fraction * shortest;
  for (int32_t c : tri)
    if ((V.rest[c] - uv).norm() <= snap) return c;

  const Vec3 l = barycentric(V.rest, tri, uv);
  const int32_t nv = V.size();
  V.resize(nv + 1);
  V.rest[nv] = uv;
  V.x[nv] = l[0] * V.x[tri[0]] + l[1] * V.x[tri[1]] + l[2] * V.x[tri[2]];
  V.v[nv] = l[0] * V.v[tri[0]] + l[1] * V.v[tri[1]] + l[2] * V.v[tri[2]];
  V.flags[nv] = kNew;

  // Close to an edge: split the edge (and the neighbour across it) so no sliver appears.
  int32_t edge = -1;
  for (int i = 0; i < 3; ++i) {
    const Vec2 a = V.rest[tri[i]], b = V.rest[tri[(i + 1) % 3]];
    const double dist = std::abs(cross2(b - a, uv - a)) / (b - a).norm();
    if (dist <= snap) edge = i;
  }
  auto add_triangle = [&](const Tri& n) {
    const int32_t id = T.size();
    T.resize(id + 1);
    T.tri[id] = n;
  };
  if (edge < 0) {
    T.tri[t] = {tri[0], tri[1], nv};
    add_triangle({tri[1], tri[2], nv});
    add_triangle({tri[2], tri[0], nv});
  } else {
    const int32_t a = tri[edge], b = tri[(edge + 1) % 3], c = tri[(edge + 2) % 3];
    // Put the new vertex exactly on the edge so both halves stay consistent with the neighbour.
    const Vec2 pa = V.rest[a], pb = V.rest[b];
    const double s = std::clamp((uv - pa).dot(pb - pa) / (pb - pa).squaredNorm(), 0.0, 1.0);
    V.rest[nv] = pa + s * (pb - pa);
    V.x[nv] = (1 - s) * V.x[a] + s * V.x[b];
    V.v[nv] = (1 - s) * V.v[a] + s * V.v[b];
    const int32_t other = sheet.topo.neighbor.size() == static_cast<size_t>(T.size()) ? sheet.topo.neighbor[t][edge] : -1;
    T.tri[t] = {a, nv, c};
    add_triangle({nv, b, c});
    if (other >= 0) {
      const Tri o = T.tri[other];
      int k = 0;
      while (!(o[k] == b && o[(k + 1) % 3] == a)) ++k;
      const int32_t d = o[(k + 2) % 3];
      T.tri[other] = {b, nv, d};
      add_triangle({nv, a, d});
    }
  }
  refresh_after_topology_change(sheet);
  return nv;
}

}  // namespace pt
