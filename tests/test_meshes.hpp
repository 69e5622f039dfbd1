// Hand-built meshes for tests: a regular grid of a rectangle, counter-clockwise, optionally jittered.
#pragma once

#include "components/sheet.hpp"
#include "systems/common/topology.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

namespace pt::test {

// nx × ny cells over [0, w] × [0, h], each cell split along alternating diagonals.
inline Sheet grid_sheet(double w, double h, int nx, int ny, double jitter = 0, uint32_t seed = 1) {
  Sheet s;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  s.verts.resize((nx + 1) * (ny + 1));
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      Vec2 p(w * i / nx, h * j / ny);
      if (i > 0 && i < nx && j > 0 && j < ny) p += Vec2(u(rng), u(rng)) * jitter * std::min(w / nx, h / ny);
      const int id = j * (nx + 1) + i;
      s.verts.rest[id] = p;
      s.verts.x[id] = Vec3(p.x(), p.y(), 0);
    }
  std::vector<Tri> tris;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int a = j * (nx + 1) + i, b = a + 1, c = a + nx + 2, d = a + nx + 1;
      if ((i + j) % 2 == 0) {
        tris.push_back({a, b, c});
        tris.push_back({a, c, d});
      } else {
        tris.push_back({a, b, d});
        tris.push_back({b, c, d});
      }
    }
  s.tris.resize(static_cast<int32_t>(tris.size()));
  s.tris.tri = tris;
  refresh_after_topology_change(s);
  return s;
}

// The two top corners of a grid_sheet of size w × h, held where they are.
inline void held_top_corners(const Sheet& s, double w, double h, std::vector<int32_t>& held,
                             std::vector<Vec3>& target) {
  held.clear();
  target.clear();
  for (int32_t i = 0; i < s.verts.size(); ++i)
    if (s.verts.rest[i].y() > h - 1e-12 && (s.verts.rest[i].x() < 1e-12 || s.verts.rest[i].x() > w - 1e-12)) {
      held.push_back(i);
      target.push_back(s.verts.x[i]);
    }
}

// A W x H rectangle as an nx x ny grid, each cell split into two counter-clockwise triangles (diagonals
// alternate so the mesh has no preferred direction); interior vertices jittered by up to `jitter` cell
// sizes in each direction.
inline Sheet alternating_grid(double W, double H, int nx, int ny, double jitter, uint32_t seed) {
  Sheet s;
  const int nv = (nx + 1) * (ny + 1);
  s.verts.resize(nv);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      Vec2 p(W * i / nx, H * j / ny);
      if (i > 0 && i < nx && j > 0 && j < ny) p += jitter * Vec2(u(rng) * W / nx, u(rng) * H / ny);
      const int id = j * (nx + 1) + i;
      s.verts.rest[id] = p;
      s.verts.x[id] = Vec3(p.x(), p.y(), 0);
    }
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int a = j * (nx + 1) + i, b = a + 1, c = a + nx + 1, d = c + 1;
      if ((i + j) % 2 == 0) {
        s.tris.tri.push_back({a, b, d});
        s.tris.tri.push_back({a, d, c});
      } else {
        s.tris.tri.push_back({a, b, c});
        s.tris.tri.push_back({b, d, c});
      }
    }
  s.tris.resize(static_cast<int32_t>(s.tris.tri.size()));
  refresh_after_topology_change(s);
  return s;
}

// Boundary vertex 0 at the origin with a fan of triangles (0, i, i+1) to ring vertices at the given
// angles (ascending, degrees, radius 1): triangle i spans the ring angles [ring[i], ring[i+1]]. The
// sheet is flat (x = (u, v, 0)). boundary_next(0) is the ring's first vertex, boundary_prev its last.
inline Vec2 polar(double deg) {
  return Vec2(std::cos(deg * std::numbers::pi / 180), std::sin(deg * std::numbers::pi / 180));
}
inline Vec3 flat(const Vec2& v) { return Vec3(v.x(), v.y(), 0); }
inline Sheet fan_sheet(const std::vector<double>& ring_deg) {
  Sheet s;
  const int32_t n = static_cast<int32_t>(ring_deg.size());
  s.verts.resize(n + 1);
  for (int32_t i = 0; i < n; ++i) s.verts.rest[i + 1] = polar(ring_deg[i]);
  for (int32_t i = 0; i <= n; ++i) s.verts.x[i] = flat(s.verts.rest[i]);
  s.tris.resize(n - 1);
  for (int32_t i = 0; i + 1 < n; ++i) s.tris.tri[i] = Tri{0, i + 1, i + 2};
  refresh_after_topology_change(s);
  return s;
}

// A W x H rectangle as an nx x ny grid (alternating diagonals) with vertical slits cut from the bottom
// edge, as a tear leaves them: slit (i, k) runs along grid column i from row 0 to row k, the vertices
// below row k are duplicated (the copies belong to the cells on the slit's right), so each lip is a
// boundary edge chain and the tip (column i, row k) is one vertex with an interior angle of 2π. k = ny
// cuts the sheet in two pieces. Columns of different slits must differ and lie strictly inside.
struct Slit {
  int i = 0, k = 0;
};
inline Sheet slit_grid(double W, double H, int nx, int ny, const std::vector<Slit>& slits) {
  Sheet s;
  auto id = [&](int i, int j) { return j * (nx + 1) + i; };
  std::vector<int32_t> copy((nx + 1) * (ny + 1), -1);
  int32_t count = (nx + 1) * (ny + 1);
  for (const Slit& sl : slits)
    for (int j = 0; j <= std::min(sl.k == ny ? ny : sl.k - 1, ny); ++j) copy[id(sl.i, j)] = count++;
  s.verts.resize(count);
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      const Vec2 p(W * i / nx, H * j / ny);
      s.verts.rest[id(i, j)] = p;
      if (copy[id(i, j)] >= 0) s.verts.rest[copy[id(i, j)]] = p;
    }
  for (int32_t v = 0; v < count; ++v) s.verts.x[v] = flat(s.verts.rest[v]);
  auto corner = [&](int ci, int i, int j) {
    // Cells in the column right of a slit take the copies.
    const int32_t v = id(i, j);
    for (const Slit& sl : slits)
      if (ci == sl.i && i == sl.i && copy[v] >= 0) return copy[v];
    return v;
  };
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int32_t a = corner(i, i, j), b = corner(i, i + 1, j), c = corner(i, i + 1, j + 1), d = corner(i, i, j + 1);
      if ((i + j) % 2 == 0) {
        s.tris.tri.push_back({a, b, c});
        s.tris.tri.push_back({a, c, d});
      } else {
        s.tris.tri.push_back({a, b, d});
        s.tris.tri.push_back({b, c, d});
      }
    }
  s.tris.resize(static_cast<int32_t>(s.tris.tri.size()));
  refresh_after_topology_change(s);
  return s;
}

// The vertex at pattern position `at` whose fan has a triangle with its centroid toward `toward` from
// `at` (of the copies of a slit's lip vertex: the one on that side); −1 if none.
inline int32_t vertex_at(const Sheet& s, const Vec2& at, const Vec2& toward = Vec2::Zero()) {
  int32_t best = -1;
  double best_dot = -1e300;
  for (int32_t v = 0; v < s.verts.size(); ++v) {
    if ((s.verts.rest[v] - at).norm() > 1e-12) continue;
    double dot = -1e300;
    for (const int32_t t : s.topo.fan(v)) {
      const Tri& c = s.tris.tri[t];
      const Vec2 centroid = (s.verts.rest[c[0]] + s.verts.rest[c[1]] + s.verts.rest[c[2]]) / 3;
      dot = std::max(dot, (centroid - at).dot(toward));
    }
    if (best < 0 || dot > best_dot) {
      best = v;
      best_dot = dot;
    }
  }
  return best;
}

}  // namespace pt::test
