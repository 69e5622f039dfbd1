#include "systems/physics/local_relaxation.hpp"

#include "systems/common/pattern_geometry.hpp"
#include "systems/common/topology.hpp"
#include "systems/physics/membrane_forces.hpp"

#include <algorithm>
#include <cmath>

namespace pt {

namespace {

// Copies sheet vertex `from` into patch vertex `to` (the arrays the implicit step reads).
void copy_vertex(const Vertices& from_verts, int32_t from, int32_t to, Vertices& to_verts) {
  to_verts.x[to] = from_verts.x[from];
  to_verts.v[to] = from_verts.v[from];
  to_verts.force[to] = Vec3::Zero();
  to_verts.rest[to] = from_verts.rest[from];
  to_verts.mass[to] = from_verts.mass[from];  // the sheet's lumped mass, whole fans included
  to_verts.flags[to] = from_verts.flags[from];
  to_verts.tear[to] = from_verts.tear[from];
}

}  // namespace

LocalRelaxationResult relax_patch_after_cut(const ImplicitParams& params, const LocalRelaxationParams& local,
                                            std::span<const Vec2> path, const std::vector<int32_t>& held,
                                            const std::vector<Vec3>& held_target, LocalRelaxationScratch& scratch,
                                            Sheet& sheet) {
  const Vertices& V = sheet.verts;
  const Triangles& T = sheet.tris;
  const Topology& topo = sheet.topo;
  const int32_t nv = V.size(), nt = T.size();
  LocalRelaxationResult result;
  scratch.patch_vertex.resize(nv, -1);
  scratch.triangle_stamp.resize(nt, -1);
  scratch.stamp += 1;
  const int32_t stamp = scratch.stamp;

  // Free vertices, in ascending id: within the radius of the path (one pass over the pattern positions,
  // a few microseconds at 10 000 triangles), and the cut's new vertices with their one-rings. They are
  // marked with patch_vertex = −2 until numbered.
  std::vector<int32_t>& free_vertices = scratch.free_list;
  free_vertices.clear();
  auto mark_free = [&](int32_t v) {
    if (scratch.patch_vertex[v] == -1) {
      scratch.patch_vertex[v] = -2;
      free_vertices.push_back(v);
    }
  };
  // The path's bounding box grown by the radius rejects most vertices with two comparisons.
  Vec2 low = path.empty() ? Vec2::Zero() : path[0], high = low;
  for (const Vec2& q : path) {
    low = low.cwiseMin(q);
    high = high.cwiseMax(q);
  }
  low.array() -= local.radius;
  high.array() += local.radius;
  for (int32_t v = 0; v < nv; ++v) {
    if (V.flags[v] & kNew) {
      mark_free(v);
      for (int32_t t : topo.fan(v))
        for (int32_t c : T.tri[t]) mark_free(c);
    }
    const Vec2& q = V.rest[v];
    if (q.x() < low.x() || q.y() < low.y() || q.x() > high.x() || q.y() > high.y()) continue;
    for (size_t k = 0; k < path.size(); ++k) {
      const Vec2& end = path[std::min(k + 1, path.size() - 1)];
      if (std::sqrt(point_segment_distance2(q, path[k], end)) <= local.radius) {
        mark_free(v);
        break;
      }
    }
  }
  std::sort(free_vertices.begin(), free_vertices.end());
  if (free_vertices.empty()) {
    result.relaxed = true;
    return result;
  }
  // An isolated free vertex (no triangle) has no corner in the copy: it stays out of the step.

  // Triangles: the free vertices' fans and their neighbours across an edge (a hinge on an edge of a fan
  // triangle has its other triangle among these), ascending.
  std::vector<int32_t>& triangles = scratch.triangles;
  triangles.clear();
  auto take = [&](int32_t t) {
    if (t >= 0 && scratch.triangle_stamp[t] != stamp) {
      scratch.triangle_stamp[t] = stamp;
      triangles.push_back(t);
    }
  };
  for (int32_t v : free_vertices)
    for (int32_t t : topo.fan(v)) {
      take(t);
      for (int32_t n : topo.neighbor[t]) take(n);
    }
  std::sort(triangles.begin(), triangles.end());

  // The copy's vertices: every corner of those triangles, ascending sheet id.
  std::vector<int32_t>& vertices = scratch.sheet_vertex;
  vertices.clear();
  for (int32_t t : triangles)
    for (int32_t c : T.tri[t]) vertices.push_back(c);
  std::sort(vertices.begin(), vertices.end());
  vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
  const int32_t pv = static_cast<int32_t>(vertices.size()), pt = static_cast<int32_t>(triangles.size());
  scratch.free.assign(pv, 0);
  for (int32_t i = 0; i < pv; ++i) {
    if (scratch.patch_vertex[vertices[i]] == -2) scratch.free[i] = 1;
    scratch.patch_vertex[vertices[i]] = i;
  }

  Sheet& patch = scratch.patch;
  patch.material = sheet.material;
  patch.verts.resize(pv);
  for (int32_t i = 0; i < pv; ++i) copy_vertex(V, vertices[i], i, patch.verts);
  patch.tris.resize(pt);
  patch.tris.pinched.assign(pt, 0);
  for (int32_t k = 0; k < pt; ++k) {
    const int32_t t = triangles[k];
    for (int c = 0; c < 3; ++c) patch.tris.tri[k][c] = scratch.patch_vertex[T.tri[t][c]];
    patch.tris.rest_inv[k] = T.rest_inv[t];
    patch.tris.rest_area[k] = T.rest_area[t];
    patch.tris.pinched[k] = pinched_fraction(T.pinched, t);
  }
  build_topology(patch.tris.tri, pv, patch.topo, scratch.piece);
  patch.topology_version += 1;
  patch.topo.version = patch.topology_version;

  // Held: the sheet's fingers in the copy at their targets, the rim (vertices not free) where it is.
  std::vector<int32_t>& patch_held = scratch.held;
  std::vector<Vec3>& patch_target = scratch.held_target;
  patch_held.clear();
  patch_target.clear();
  for (int32_t i = 0; i < pv; ++i)
    if (!scratch.free[i]) {
      patch_held.push_back(i);
      patch_target.push_back(patch.verts.x[i]);
    }
  const auto rim_end = static_cast<std::ptrdiff_t>(patch_held.size());
  for (size_t k = 0; k < held.size(); ++k) {
    const int32_t i = held[k] >= 0 && held[k] < nv ? scratch.patch_vertex[held[k]] : -1;
    if (i < 0) continue;
    if (scratch.free[i]) {
      patch_held.push_back(i);
      patch_target.push_back(held_target[k]);
    } else {  // a finger on the rim: where the finger holds it rather than where it is
      patch_target[std::lower_bound(patch_held.begin(), patch_held.begin() + rim_end, i) - patch_held.begin()] =
          held_target[k];
    }
  }

  // A fresh solver for each patch (its pattern is new anyway), dropped after the step: the spin brake's level
  // would otherwise carry from one patch to another, and the sheet keeps no factor it will not reuse.
  ImplicitSolverPtr solver;
  result.triangles = pt;
  result.relaxed = implicit_substep(params, patch_held, patch_target, solver, patch);
  if (result.relaxed) {
    for (int32_t i = 0; i < pv; ++i) {
      if (!scratch.free[i]) continue;
      sheet.verts.x[vertices[i]] = patch.verts.x[i];
      sheet.verts.v[vertices[i]] = patch.verts.v[i];
      result.free_vertices += 1;
    }
  }
  for (int32_t v : vertices) scratch.patch_vertex[v] = -1;
  for (int32_t v : free_vertices) scratch.patch_vertex[v] = -1;
  return result;
}

}  // namespace pt
