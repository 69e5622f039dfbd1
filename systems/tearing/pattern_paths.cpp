// Shortest paths inside a piece of the torn pattern: segment tests against the piece's boundary edges
// in a uniform grid, and Dijkstra over the visibility graph of the reflex boundary vertices.
#include "systems/tearing/pattern_paths.hpp"

#include "systems/common/pattern_geometry.hpp"
#include "systems/common/topology.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace pt {
namespace {

constexpr double kTwoPi = 2 * std::numbers::pi;
constexpr int32_t kMaxCellsPerSide = 4096;

// Counter-clockwise angle from a to b in [0, 2π).
double ccw_angle(const Vec2& a, const Vec2& b) {
  double angle = std::atan2(cross(a, b), a.dot(b));
  if (angle < 0) angle += kTwoPi;
  return angle;
}

bool is_boundary(const Topology& topo, int32_t v) { return v >= 0 && topo.boundary_next[v] >= 0; }

// dir leaves boundary vertex v into the material or along its boundary: within the closed interior
// angle, measured counter-clockwise from the edge to boundary_next (the material is on the left).
bool in_closed_wedge(const Topology& topo, const std::vector<Vec2>& rest, int32_t v, const Vec2& dir,
                     double angle_tolerance) {
  const double interior = interior_pattern_angle(topo, rest, v);
  const double at = ccw_angle(rest[topo.boundary_next[v]] - rest[v], dir);
  return at <= interior + angle_tolerance || at >= kTwoPi - angle_tolerance;
}

// The open segments a–b and c–e cross at one point inside both (each strictly separates the other's
// ends). Touching, collinear overlap and ends on the other segment are not crossings: the vertex tests
// of segment_in_pattern decide those.
bool crosses(const Vec2& a, const Vec2& d, double length, const Vec2& c, const Vec2& e, double tol) {
  const double o1 = cross(d, c - a) / length, o2 = cross(d, e - a) / length;
  if (!((o1 > tol && o2 < -tol) || (o1 < -tol && o2 > tol))) return false;
  const Vec2 f = e - c;
  const double lf = f.norm();
  if (!(lf > tol)) return false;
  const double o3 = cross(f, a - c) / lf, o4 = cross(f, a + d - c) / lf;
  return (o3 > tol && o4 < -tol) || (o3 < -tol && o4 > tol);
}

int32_t clamp_cell(double x, double origin, double cell, int32_t n) {
  const double i = std::floor((x - origin) / cell);
  if (!(i > 0)) return 0;  // also NaN
  return i >= n - 1 ? n - 1 : static_cast<int32_t>(i);
}

// Visits the cells the segment a → b (widened by tol) passes through, column by column: f(cell) returns
// false to stop. Returns false when stopped.
template <class F>
bool for_cells_along(const PatternBoundary& g, const Vec2& a, const Vec2& b, double tol, F&& f) {
  const double x_min = std::min(a.x(), b.x()) - tol, x_max = std::max(a.x(), b.x()) + tol;
  const int32_t ix0 = clamp_cell(x_min, g.origin.x(), g.cell, g.nx);
  const int32_t ix1 = clamp_cell(x_max, g.origin.x(), g.cell, g.nx);
  const Vec2 d = b - a;
  for (int32_t ix = ix0; ix <= ix1; ++ix) {
    const double lo = std::max(x_min, g.origin.x() + ix * g.cell);
    const double hi = std::min(x_max, g.origin.x() + (ix + 1) * g.cell);
    double y0, y1;
    if (std::abs(d.x()) > tol) {
      const double s0 = std::clamp((lo - a.x()) / d.x(), 0.0, 1.0);
      const double s1 = std::clamp((hi - a.x()) / d.x(), 0.0, 1.0);
      y0 = a.y() + s0 * d.y();
      y1 = a.y() + s1 * d.y();
      if (y0 > y1) std::swap(y0, y1);
    } else {
      y0 = std::min(a.y(), b.y());
      y1 = std::max(a.y(), b.y());
    }
    const int32_t iy0 = clamp_cell(y0 - tol, g.origin.y(), g.cell, g.ny);
    const int32_t iy1 = clamp_cell(y1 + tol, g.origin.y(), g.cell, g.ny);
    for (int32_t iy = iy0; iy <= iy1; ++iy)
      if (!f(iy * g.nx + ix)) return false;
  }
  return true;
}

// A shortest path bends at reflex vertex w only where its segment is tangent to the boundary there:
// both boundary neighbours of w on one side of the segment's line (or on it).
bool tangent_at(const Topology& topo, const std::vector<Vec2>& rest, int32_t w, const Vec2& line, double tol) {
  const double l = line.norm();
  if (!(l > 0)) return false;
  const double cn = cross(line, rest[topo.boundary_next[w]] - rest[w]) / l;
  const double cp = cross(line, rest[topo.boundary_prev[w]] - rest[w]) / l;
  return !((cn > tol && cp < -tol) || (cn < -tol && cp > tol));
}

}  // namespace

int32_t vertex_piece(const Topology& topo, const std::vector<int32_t>& piece, int32_t v) {
  if (v < 0 || v >= topo.vertex_count() || topo.fans[v].count == 0) return -1;
  return piece[topo.fan(v)[0]];
}

void build_pattern_boundary(const Topology& topo, const std::vector<Vec2>& rest, const std::vector<int32_t>& piece,
                            int32_t piece_id, const PatternPathParams& params, PatternBoundary& out) {
  out.piece = piece_id;
  out.edges.clear();
  out.reflex.clear();
  out.angle_tolerance = params.angle_tolerance;
  Vec2 lo = Vec2::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const int32_t v : topo.boundary_vertices) {
    if (vertex_piece(topo, piece, v) != piece_id) continue;
    out.edges.push_back(v);
    if (interior_pattern_angle(topo, rest, v) > std::numbers::pi + params.angle_tolerance) out.reflex.push_back(v);
    lo = lo.cwiseMin(rest[v]);
    hi = hi.cwiseMax(rest[v]);
  }
  const int32_t count = static_cast<int32_t>(out.edges.size());
  if (count == 0) {
    out.origin = Vec2::Zero();
    out.cell = 1;
    out.nx = out.ny = 1;
    out.tolerance = 0;
    out.cell_start.assign(2, 0);
    out.cell_edges.clear();
    return;
  }
  const Vec2 size = hi - lo;
  const double scale = std::max(size.maxCoeff(), std::numeric_limits<double>::min());
  out.tolerance = params.relative_tolerance * scale;
  // About one edge per cell: a segment test then looks at O(√E) edges.
  const int32_t per_side = std::clamp(static_cast<int32_t>(std::ceil(std::sqrt(double(count)))), 1, kMaxCellsPerSide);
  out.cell = scale / per_side;
  out.origin = lo - Vec2::Constant(2 * out.tolerance);
  const Vec2 span = size + Vec2::Constant(4 * out.tolerance);
  out.nx = std::clamp(static_cast<int32_t>(std::ceil(span.x() / out.cell)), 1, kMaxCellsPerSide);
  out.ny = std::clamp(static_cast<int32_t>(std::ceil(span.y() / out.cell)), 1, kMaxCellsPerSide);

  // Counting pass, then fill (CSR): each edge goes to the cells its bounding box (widened by the
  // tolerance) covers, so a segment within the tolerance of it visits one of them.
  const int32_t cells = out.nx * out.ny;
  out.cell_start.assign(cells + 1, 0);
  auto each_cell = [&](int32_t k, auto&& f) {
    const Vec2& a = rest[out.edges[k]];
    const Vec2& b = rest[topo.boundary_next[out.edges[k]]];
    const double t = out.tolerance;
    const int32_t ix0 = clamp_cell(std::min(a.x(), b.x()) - t, out.origin.x(), out.cell, out.nx);
    const int32_t ix1 = clamp_cell(std::max(a.x(), b.x()) + t, out.origin.x(), out.cell, out.nx);
    const int32_t iy0 = clamp_cell(std::min(a.y(), b.y()) - t, out.origin.y(), out.cell, out.ny);
    const int32_t iy1 = clamp_cell(std::max(a.y(), b.y()) + t, out.origin.y(), out.cell, out.ny);
    for (int32_t iy = iy0; iy <= iy1; ++iy)
      for (int32_t ix = ix0; ix <= ix1; ++ix) f(iy * out.nx + ix);
  };
  for (int32_t k = 0; k < count; ++k) each_cell(k, [&](int32_t c) { ++out.cell_start[c + 1]; });
  for (int32_t c = 0; c < cells; ++c) out.cell_start[c + 1] += out.cell_start[c];
  out.cell_edges.resize(out.cell_start[cells]);
  // Fill in ascending edge order per cell (deterministic), using cell_start as cursors then shifting back.
  for (int32_t k = 0; k < count; ++k) each_cell(k, [&](int32_t c) { out.cell_edges[out.cell_start[c]++] = k; });
  for (int32_t c = cells; c > 0; --c) out.cell_start[c] = out.cell_start[c - 1];
  out.cell_start[0] = 0;
}

bool segment_in_pattern(const PatternBoundary& boundary, const Topology& topo, const std::vector<Vec2>& rest,
                        const Vec2& a, int32_t a_vertex, const Vec2& b, int32_t b_vertex,
                        SegmentQueryScratch& scratch) {
  const double tol = boundary.tolerance, atol = boundary.angle_tolerance;
  const Vec2 d = b - a;
  const double length = d.norm();
  if (!(length > tol)) return false;
  if (is_boundary(topo, a_vertex) && !in_closed_wedge(topo, rest, a_vertex, d, atol)) return false;
  if (is_boundary(topo, b_vertex) && !in_closed_wedge(topo, rest, b_vertex, -d, atol)) return false;

  if (scratch.stamp.size() < boundary.edges.size()) scratch.stamp.resize(boundary.edges.size(), 0);
  if (++scratch.query == 0) {
    std::fill(scratch.stamp.begin(), scratch.stamp.end(), 0);
    scratch.query = 1;
  }
  const uint32_t query = scratch.query;
  const Vec2 unit = d / length;
  return for_cells_along(boundary, a, b, tol, [&](int32_t cell) {
    for (int32_t i = boundary.cell_start[cell]; i < boundary.cell_start[cell + 1]; ++i) {
      const int32_t k = boundary.cell_edges[i];
      if (scratch.stamp[k] == query) continue;
      scratch.stamp[k] = query;
      const int32_t v = boundary.edges[k];
      const Vec2& c = rest[v];
      if (crosses(a, d, length, c, rest[topo.boundary_next[v]], tol)) return false;
      // Boundary vertex v on the open segment (each boundary vertex starts one edge, so each is tested
      // once): the segment passes through it and must stay in its interior angle on both sides, which
      // tells a graze along a lip or around a corner (allowed) from a pass across the slit (not).
      if (v == a_vertex || v == b_vertex) continue;
      const Vec2 ac = c - a;
      if (std::abs(cross(unit, ac)) > tol) continue;
      const double s = unit.dot(ac);
      if (!(s > tol && s < length - tol)) continue;
      const double slack = std::max(atol, tol / std::min(s, length - s));
      if (!in_closed_wedge(topo, rest, v, a - c, slack) || !in_closed_wedge(topo, rest, v, b - c, slack)) return false;
    }
    return true;
  });
}

void shortest_pattern_paths(const PatternBoundary& boundary, const Topology& topo, const std::vector<Vec2>& rest,
                            int32_t source, std::span<const int32_t> targets, PatternPathScratch& scratch,
                            PatternPaths& out) {
  const int32_t target_count = static_cast<int32_t>(targets.size());
  out.paths.assign(target_count, PatternPath{});
  out.points.clear();
  out.point_vertex.clear();
  out.visibility_tests = 0;
  if (source < 0 || source >= topo.vertex_count()) return;
  const Vec2& ps = rest[source];
  auto boundary_or_none = [&](int32_t v) { return is_boundary(topo, v) ? v : -1; };
  const int32_t source_vertex = boundary_or_none(source);  // an interior source (a finger) leaves in any direction

  // Straight segments first: when every target sees the source no graph is built.
  int32_t blocked = 0;
  for (int32_t i = 0; i < target_count; ++i) {
    const int32_t t = targets[i];
    if (t < 0 || t >= topo.vertex_count() || t == source) continue;
    ++out.visibility_tests;
    if (segment_in_pattern(boundary, topo, rest, ps, source_vertex, rest[t], boundary_or_none(t), scratch.query)) {
      PatternPath& path = out.paths[i];
      path.reachable = path.straight = true;
      path.length = (rest[t] - ps).norm();
      path.first_direction = (rest[t] - ps) / path.length;
      path.point_begin = static_cast<int32_t>(out.points.size());
      out.points.push_back(rest[t]);
      out.point_vertex.push_back(t);
      path.point_end = path.point_begin + 1;
    } else {
      ++blocked;
    }
  }
  if (blocked == 0) return;

  // Dijkstra over the visibility graph, edges tested when their tail is settled. Nodes: 0 the source,
  // 1..target_count the targets (ends only), then the reflex vertices (the only places a shortest path
  // bends). Array scan for the minimum: few nodes, and ties go to the lowest index.
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<int32_t>& node = scratch.node_vertex;
  node.clear();
  node.push_back(source);
  for (int32_t i = 0; i < target_count; ++i) node.push_back(targets[i]);
  for (const int32_t r : boundary.reflex)
    if (r != source) node.push_back(r);
  const int32_t n = static_cast<int32_t>(node.size());
  scratch.distance.assign(n, inf);
  scratch.previous.assign(n, -1);
  scratch.done.assign(n, 0);
  for (int32_t i = 0; i < target_count; ++i) {
    const int32_t t = targets[i];
    // Straight, or not a vertex to reach: settled already, never a corner.
    if (out.paths[i].straight || t < 0 || t >= topo.vertex_count() || t == source) scratch.done[1 + i] = 1;
  }
  scratch.distance[0] = 0;
  const double tol = boundary.tolerance;
  while (blocked > 0) {
    int32_t u = -1;
    for (int32_t k = 0; k < n; ++k)
      if (!scratch.done[k] && scratch.distance[k] < inf && (u < 0 || scratch.distance[k] < scratch.distance[u])) u = k;
    if (u < 0) break;
    scratch.done[u] = 1;
    if (u >= 1 && u <= target_count) {
      --blocked;
      continue;
    }
    const int32_t vu = node[u];
    const Vec2& pu = rest[vu];
    for (int32_t k = 1; k < n; ++k) {
      if (scratch.done[k]) continue;
      const int32_t vk = node[k];
      const Vec2 line = rest[vk] - pu;
      const double candidate = scratch.distance[u] + line.norm();
      if (!(candidate < scratch.distance[k])) continue;
      const bool corner = k > target_count;
      if (corner && !tangent_at(topo, rest, vk, line, tol)) continue;
      if (u > 0 && !tangent_at(topo, rest, vu, line, tol)) continue;
      ++out.visibility_tests;
      if (!segment_in_pattern(boundary, topo, rest, pu, u == 0 ? source_vertex : vu, rest[vk], boundary_or_none(vk),
                              scratch.query))
        continue;
      scratch.distance[k] = candidate;
      scratch.previous[k] = u;
    }
  }

  for (int32_t i = 0; i < target_count; ++i) {
    PatternPath& path = out.paths[i];
    const int32_t k = 1 + i;
    if (path.straight || scratch.distance[k] == inf || targets[i] == source) continue;
    std::vector<int32_t>& chain = scratch.chain;
    chain.clear();
    for (int32_t m = k; m > 0; m = scratch.previous[m]) chain.push_back(m);
    std::reverse(chain.begin(), chain.end());
    path.reachable = true;
    path.length = scratch.distance[k];
    path.first_corner = node[chain.front()];
    path.first_direction = (rest[path.first_corner] - ps).normalized();
    path.point_begin = static_cast<int32_t>(out.points.size());
    for (const int32_t m : chain) {
      out.points.push_back(rest[node[m]]);
      out.point_vertex.push_back(node[m]);
    }
    path.point_end = static_cast<int32_t>(out.points.size());
  }
}

}  // namespace pt
