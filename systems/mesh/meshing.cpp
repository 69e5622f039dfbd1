// Meshing of the sheet's outline (docs/architecture.md "Data and its invariants"; docs/physics.md "Fingers"):
// validation of the outline polygon, presets, and the CGAL constrained Delaunay refinement. CGAL stays inside
// this file so no other translation unit pays for its headers.
#include "systems/mesh/meshing.hpp"
#include "systems/common/pattern_geometry.hpp"

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Delaunay_mesh_face_base_2.h>
#include <CGAL/Delaunay_mesh_size_criteria_2.h>
#include <CGAL/Delaunay_mesh_vertex_base_2.h>
#include <CGAL/Delaunay_mesher_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <numbers>
#include <random>
#include <utility>

namespace pt {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_2;

// Exact sign of the orientation of (a, b, c): robust decisions for the self-intersection test, so a
// nearly-touching outline is judged the same way CGAL will judge it when meshing.
int orient(const Vec2& a, const Vec2& b, const Vec2& c) {
  return static_cast<int>(CGAL::orientation(Point(a.x(), a.y()), Point(b.x(), b.y()), Point(c.x(), c.y())));
}

// c collinear with [a, b] and inside its bounding box.
bool on_segment(const Vec2& a, const Vec2& b, const Vec2& c) {
  return std::min(a.x(), b.x()) <= c.x() && c.x() <= std::max(a.x(), b.x()) && std::min(a.y(), b.y()) <= c.y() &&
         c.y() <= std::max(a.y(), b.y());
}

// Closed segments [a, b] and [c, d] share at least one point.
bool segments_touch(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d) {
  const int o1 = orient(a, b, c), o2 = orient(a, b, d), o3 = orient(c, d, a), o4 = orient(c, d, b);
  if (o1 != o2 && o3 != o4 && o1 * o2 <= 0 && o3 * o4 <= 0) {
    if (o1 != 0 || o2 != 0) return true;
  }
  if (o1 == 0 && on_segment(a, b, c)) return true;
  if (o2 == 0 && on_segment(a, b, d)) return true;
  if (o3 == 0 && on_segment(c, d, a)) return true;
  if (o4 == 0 && on_segment(c, d, b)) return true;
  return false;
}

double signed_area(const std::vector<Vec2>& poly) {
  // Shoelace around the first vertex: smaller terms, less cancellation for sheets far from the origin.
  double twice = 0;
  const Vec2& o = poly[0];
  for (size_t i = 1; i + 1 < poly.size(); ++i) {
    const Vec2 a = poly[i] - o, b = poly[i + 1] - o;
    twice += a.x() * b.y() - a.y() * b.x();
  }
  return 0.5 * twice;
}

std::string fmt_point(const Vec2& p) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "(%.9g, %.9g)", p.x(), p.y());
  return buf;
}

// Edge i runs from vertex i to vertex i+1 (mod n); named by its ends for the message.
std::string fmt_edge(const std::vector<Vec2>& poly, size_t i) {
  return "edge " + std::to_string(i) + " " + fmt_point(poly[i]) + "-" + fmt_point(poly[(i + 1) % poly.size()]);
}

// First pair of edges that touch where they should not, or {-1, -1}. Edges are swept in order of their
// lowest x so only pairs whose x-ranges overlap are tested: O(n log n + k) for ordinary outlines,
// O(n²) at worst (every edge spans the same x-range).
std::pair<long, long> find_self_intersection(const std::vector<Vec2>& poly) {
  const size_t n = poly.size();
  std::vector<size_t> order(n);
  for (size_t i = 0; i < n; ++i) order[i] = i;
  auto lo_x = [&](size_t e) { return std::min(poly[e].x(), poly[(e + 1) % n].x()); };
  auto hi_x = [&](size_t e) { return std::max(poly[e].x(), poly[(e + 1) % n].x()); };
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    const double la = lo_x(a), lb = lo_x(b);
    return la < lb || (la == lb && a < b);
  });
  std::pair<long, long> first{-1, -1};
  for (size_t oi = 0; oi < n; ++oi) {
    const size_t e = order[oi];
    const Vec2& a = poly[e];
    const Vec2& b = poly[(e + 1) % n];
    const double ey0 = std::min(a.y(), b.y()), ey1 = std::max(a.y(), b.y()), ex1 = hi_x(e);
    for (size_t oj = oi + 1; oj < n && lo_x(order[oj]) <= ex1; ++oj) {
      const size_t f = order[oj];
      const Vec2& c = poly[f];
      const Vec2& d = poly[(f + 1) % n];
      if (std::max(c.y(), d.y()) < ey0 || std::min(c.y(), d.y()) > ey1) continue;
      const size_t lo = std::min(e, f), hi = std::max(e, f);
      bool bad;
      if (hi == lo + 1 || (lo == 0 && hi == n - 1)) {
        // Adjacent edges share one vertex; they overlap only when they fold back onto each other.
        const size_t shared = (hi == lo + 1) ? hi : 0;
        const Vec2& s = poly[shared];
        const Vec2& p = poly[(shared + n - 1) % n];
        const Vec2& q = poly[(shared + 1) % n];
        bad = n > 3 && orient(p, s, q) == 0 && (p - s).dot(q - s) > 0;
      } else {
        bad = segments_touch(a, b, c, d);
      }
      // Report the pair with the lowest edge ids so the message does not depend on the sweep order.
      if (bad && (first.first < 0 || std::make_pair(long(lo), long(hi)) < first)) first = {long(lo), long(hi)};
    }
  }
  return first;
}

// ---- CGAL mesher -------------------------------------------------------------------------------------

// `exact` indexes the exact input coordinates (augmented outline, then interior required points) a vertex
// must get back after meshing; −1 for Steiner vertices. `id` is the output index during extraction.
struct VertexInfo {
  int32_t exact = -1;
  int32_t id = -1;
};
using Vb = CGAL::Triangulation_vertex_base_with_info_2<VertexInfo, K, CGAL::Delaunay_mesh_vertex_base_2<K>>;
using Fb = CGAL::Delaunay_mesh_face_base_2<K>;
using Tds = CGAL::Triangulation_data_structure_2<Vb, Fb>;
using CDT = CGAL::Constrained_Delaunay_triangulation_2<K, Tds, CGAL::Exact_predicates_tag>;
using Criteria = CGAL::Delaunay_mesh_size_criteria_2<CDT>;
using Mesher = CGAL::Delaunay_mesher_2<CDT, Criteria>;

// The request after validation: the outline with required points on its edges spliced in (`ring`), the
// interior required points, and the meshing frame (rotation about the bounding-box centre, which keeps
// coordinates small so the rotation loses little precision).
struct Problem {
  std::vector<Vec2> exact;          // ring vertices [0, ring_size), then interior required points
  int32_t ring_size = 0;
  std::vector<int32_t> required_slot;  // required point i → index into `exact`
  std::vector<Vec2> frame;          // `exact` in the meshing frame
  Vec2 center = Vec2::Zero();
  double cos_r = 1, sin_r = 0;
  double diameter = 0;
  double area = 0;
};

Vec2 to_frame(const Problem& pb, const Vec2& p) {
  const Vec2 d = p - pb.center;
  return Vec2(pb.cos_r * d.x() - pb.sin_r * d.y(), pb.sin_r * d.x() + pb.cos_r * d.y());
}

Vec2 from_frame(const Problem& pb, const Vec2& q) {
  return Vec2(pb.cos_r * q.x() + pb.sin_r * q.y(), -pb.sin_r * q.x() + pb.cos_r * q.y()) + pb.center;
}

Problem prepare(const MeshRequest& rq) {
  Problem pb;
  const auto& outline = rq.outline;
  const size_t n = outline.size();
  Vec2 lo = outline[0], hi = outline[0];
  for (const Vec2& p : outline) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  pb.diameter = (hi - lo).norm();
  pb.center = 0.5 * (lo + hi);
  pb.area = signed_area(outline);
  const double rad = rq.rotation_deg * std::numbers::pi / 180;
  if (rq.rotation_deg != 0) pb.cos_r = std::cos(rad), pb.sin_r = std::sin(rad);
  // Points closer than this to the outline are on it (point_on_sheet).
  const double snap = outline_snap_distance(outline);

  const size_t m = rq.required_points.size();
  std::vector<int32_t> at_vertex(m, -1);                        // outline vertex it coincides with
  std::vector<std::vector<std::pair<double, size_t>>> on_edge(n);  // (parameter, required id)
  std::vector<Vec2> interior;
  std::vector<int32_t> interior_of(m, -1);
  for (size_t i = 0; i < m; ++i) {
    const Vec2& p = rq.required_points[i];
    if (!std::isfinite(p.x()) || !std::isfinite(p.y()))
      throw GeometryError("required point " + std::to_string(i) + " has a non-finite coordinate");
    if (!point_on_sheet(outline, p)) throw GeometryError("point " + fmt_point(p) + " is outside the outline");
    for (size_t v = 0; v < n && at_vertex[i] < 0; ++v)
      if ((outline[v] - p).squaredNorm() <= snap * snap) at_vertex[i] = int32_t(v);
    if (at_vertex[i] >= 0) continue;
    size_t best_edge = n;
    double best_d2 = snap * snap, best_t = 0;
    for (size_t e = 0; e < n; ++e) {
      double t;
      const double d2 = point_segment_distance2(p, outline[e], outline[(e + 1) % n], &t);
      if (d2 <= best_d2) best_edge = e, best_d2 = d2, best_t = t;
    }
    if (best_edge < n) {
      on_edge[best_edge].emplace_back(best_t, i);
      continue;
    }
    // Interior; the same point given twice gets one vertex.
    for (size_t j = 0; j < interior.size() && interior_of[i] < 0; ++j)
      if (interior[j] == p) interior_of[i] = int32_t(j);
    if (interior_of[i] < 0) {
      interior_of[i] = int32_t(interior.size());
      interior.push_back(p);
    }
  }

  pb.required_slot.assign(m, -1);
  std::vector<int32_t> ring_of_vertex(n);
  for (size_t e = 0; e < n; ++e) {
    ring_of_vertex[e] = int32_t(pb.exact.size());
    pb.exact.push_back(outline[e]);
    auto& splits = on_edge[e];
    std::sort(splits.begin(), splits.end());
    for (const auto& [t, i] : splits) {
      const Vec2& p = rq.required_points[i];
      if (pb.exact.back() != p) pb.exact.push_back(p);
      pb.required_slot[i] = int32_t(pb.exact.size()) - 1;
    }
  }
  pb.ring_size = int32_t(pb.exact.size());
  for (size_t i = 0; i < m; ++i) {
    if (at_vertex[i] >= 0) pb.required_slot[i] = ring_of_vertex[at_vertex[i]];
    if (interior_of[i] >= 0) pb.required_slot[i] = pb.ring_size + interior_of[i];
  }
  pb.exact.insert(pb.exact.end(), interior.begin(), interior.end());
  for (const Vec2& p : pb.exact) pb.frame.push_back(to_frame(pb, p));
  return pb;
}

// Sparse Steiner points: a jittered square lattice of spacing 3 S aligned with the meshing frame.
// Used for seed != 0 or a rotated frame: Delaunay refinement alone is nearly invariant under rotation
// (the circumcentres it inserts rotate with the sheet), so without these a rotated frame or another seed
// would give the same connectivity.
std::vector<Point> steiner_lattice(const Problem& pb, const MeshRequest& rq, double size) {
  std::vector<Point> out;
  const std::vector<Vec2> ring(pb.frame.begin(), pb.frame.begin() + pb.ring_size);
  const size_t r = ring.size();
  Vec2 lo = ring[0], hi = ring[0];
  for (const Vec2& p : ring) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const Vec2 extent = hi - lo;
  // Never more than ~4M lattice sites over the bounding box (thin outlines).
  const double g = std::max(3 * size, std::sqrt(extent.prod() / 4e6));
  const int64_t nx = int64_t(extent.x() / g) + 1, ny = int64_t(extent.y() / g) + 1;
  if (nx < 1 || ny < 1) return out;
  std::mt19937_64 rng(rq.seed != 0 ? rq.seed : 0x9E3779B97F4A7C15ull);
  // Uniform in [0, 1) from the raw 64 bits: std::uniform_real_distribution is not bit-exact across
  // standard libraries, this is.
  auto uniform = [&] { return double(rng() >> 11) * 0x1.0p-53; };
  const double ox = uniform() * g, oy = uniform() * g;
  const double jitter = 0.25 * g;  // per axis, so a site moves at most 0.36 g
  // A site is kept when its unjittered position is inside and farther than this from the outline, so the
  // jittered point is inside and at least 0.75 S from the outline: it cannot encroach a boundary segment
  // of length ≤ S nor make a sliver against it.
  const double clear = 0.75 * size + jitter * std::sqrt(2.0);

  // Outline edges bucketed in cells of size g (clear < g, so the 3x3 block around a site's cell holds
  // every edge within `clear`); an edge is registered by sampling it at steps of g/2.
  std::vector<std::vector<int32_t>> cells(size_t(nx * ny));
  auto cell_of = [&](const Vec2& p, int64_t& cx, int64_t& cy) {
    cx = std::clamp<int64_t>(int64_t(std::floor((p.x() - lo.x()) / g)), 0, nx - 1);
    cy = std::clamp<int64_t>(int64_t(std::floor((p.y() - lo.y()) / g)), 0, ny - 1);
  };
  for (size_t e = 0; e < r; ++e) {
    const Vec2& a = ring[e];
    const Vec2& b = ring[(e + 1) % r];
    const int steps = int(std::ceil((b - a).norm() / (0.5 * g))) + 1;
    int64_t last = -1;
    for (int k = 0; k <= steps; ++k) {
      int64_t cx, cy;
      cell_of(a + (b - a) * (double(k) / steps), cx, cy);
      if (cy * nx + cx == last) continue;
      last = cy * nx + cx;
      for (int64_t y = std::max<int64_t>(0, cy - 1); y <= std::min(ny - 1, cy + 1); ++y)
        for (int64_t x = std::max<int64_t>(0, cx - 1); x <= std::min(nx - 1, cx + 1); ++x) {
          auto& c = cells[size_t(y * nx + x)];
          if (c.empty() || c.back() != int32_t(e)) c.push_back(int32_t(e));
        }
    }
  }

  std::vector<double> crossings;
  for (int64_t j = 0;; ++j) {
    const double y = lo.y() + oy + double(j) * g;
    if (y >= hi.y()) break;
    // Inside test by scanline: the row's crossings with the outline, sorted (half-open rule on y).
    crossings.clear();
    for (size_t e = 0; e < r; ++e) {
      const Vec2& a = ring[e];
      const Vec2& b = ring[(e + 1) % r];
      if ((a.y() > y) != (b.y() > y)) crossings.push_back(a.x() + (y - a.y()) / (b.y() - a.y()) * (b.x() - a.x()));
    }
    std::sort(crossings.begin(), crossings.end());
    size_t passed = 0;
    for (int64_t i = 0;; ++i) {
      const double x = lo.x() + ox + double(i) * g;
      if (x >= hi.x()) break;
      // Always draw the jitter so each site's value depends only on its position in the lattice.
      const double jx = (uniform() - 0.5) * 2 * jitter, jy = (uniform() - 0.5) * 2 * jitter;
      while (passed < crossings.size() && crossings[passed] <= x) ++passed;
      if (passed % 2 == 0) continue;
      const Vec2 site(x, y);
      int64_t cx, cy;
      cell_of(site, cx, cy);
      bool ok = true;
      for (int32_t e : cells[size_t(cy * nx + cx)]) {
        if (point_segment_distance2(site, ring[e], ring[(size_t(e) + 1) % r]) < clear * clear) {
          ok = false;
          break;
        }
      }
      const Vec2 q(x + jx, y + jy);
      for (size_t k = pb.ring_size; k < pb.frame.size() && ok; ++k)
        ok = (pb.frame[k] - q).squaredNorm() >= (0.75 * size) * (0.75 * size);
      for (size_t k = 0; k < rq.required_segments.size() && ok; ++k) {
        const auto& [a, b] = rq.required_segments[k];
        ok = point_segment_distance2(q, pb.frame[pb.required_slot[a]], pb.frame[pb.required_slot[b]]) >=
             (0.75 * size) * (0.75 * size);
      }
      if (ok) out.emplace_back(q.x(), q.y());
    }
  }
  return out;
}

// One constrained Delaunay refinement at edge-length bound `size`; returns the in-domain triangle count, or
// −1 as soon as the triangulation holds more than `max_vertices` vertices.
long refine(const Problem& pb, const MeshRequest& rq, double aspect_bound, double size, int64_t max_vertices,
            CDT& cdt) {
  std::vector<CDT::Vertex_handle> ring;
  ring.reserve(pb.ring_size);
  for (int32_t i = 0; i < pb.ring_size; ++i) {
    auto v = cdt.insert(Point(pb.frame[i].x(), pb.frame[i].y()));
    v->info().exact = i;
    ring.push_back(v);
  }
  for (int32_t i = 0; i < pb.ring_size; ++i) cdt.insert_constraint(ring[i], ring[(i + 1) % pb.ring_size]);
  std::vector<CDT::Vertex_handle> vertex_of_slot = ring;
  for (size_t j = pb.ring_size; j < pb.frame.size(); ++j) {
    auto v = cdt.insert(Point(pb.frame[j].x(), pb.frame[j].y()));
    v->info().exact = int32_t(j);
    vertex_of_slot.push_back(v);
  }
  // Refinement splits a constrained segment where it must, so each stays a chain of mesh edges.
  for (const auto& [a, b] : rq.required_segments)
    cdt.insert_constraint(vertex_of_slot[pb.required_slot[a]], vertex_of_slot[pb.required_slot[b]]);
  if (rq.seed != 0 || rq.rotation_deg != 0) {
    const std::vector<Point> sites = steiner_lattice(pb, rq, size);
    cdt.insert(sites.begin(), sites.end());  // range insertion sorts spatially: fast for many points
  }
  if (static_cast<int64_t>(cdt.number_of_vertices()) > max_vertices) return -1;
  // One point at a time, so that an outline with features far below the mesh size (a 0.3 m x 1e-7 m strip
  // needs millions of triangles at any size bound) is given up at `max_vertices` before it fills memory.
  // The same refinement as refine_mesh(): the same queues processed in the same order.
  Mesher mesher(cdt, Criteria(aspect_bound, size));
  mesher.init();
  while (mesher.step_by_step_refine_mesh())
    if (static_cast<int64_t>(cdt.number_of_vertices()) > max_vertices) return -1;
  long count = 0;
  for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) count += f->is_in_domain() ? 1 : 0;
  return count;
}

// Compact, deterministic output: vertices sorted by pattern position, each triangle starting at its
// smallest vertex id (orientation kept), triangles sorted. Outline and required vertices get their exact
// input coordinates back; Steiner vertices are rotated back from the meshing frame.
void extract(const Problem& pb, CDT& cdt, std::vector<Vec2>& rest, std::vector<Tri>& tri,
             std::vector<int32_t>& required_vertex) {
  std::vector<CDT::Vertex_handle> used;
  std::vector<CDT::Vertex_handle> slot(pb.exact.size());
  for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) {
    if (!f->is_in_domain()) continue;
    for (int k = 0; k < 3; ++k) {
      auto v = f->vertex(k);
      if (v->info().id >= 0) continue;
      v->info().id = int32_t(used.size());
      used.push_back(v);
      if (v->info().exact >= 0) slot[v->info().exact] = v;
    }
  }
  std::vector<Vec2> pos(used.size());
  for (size_t i = 0; i < used.size(); ++i) {
    const int32_t e = used[i]->info().exact;
    pos[i] = e >= 0 ? pb.exact[e] : from_frame(pb, Vec2(used[i]->point().x(), used[i]->point().y()));
  }
  std::vector<int32_t> order(used.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = int32_t(i);
  std::sort(order.begin(), order.end(), [&](int32_t a, int32_t b) {
    if (pos[a].x() != pos[b].x()) return pos[a].x() < pos[b].x();
    if (pos[a].y() != pos[b].y()) return pos[a].y() < pos[b].y();
    return a < b;
  });
  std::vector<int32_t> remap(used.size());
  rest.resize(used.size());
  for (size_t k = 0; k < order.size(); ++k) {
    remap[order[k]] = int32_t(k);
    rest[k] = pos[order[k]];
  }
  tri.clear();
  for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) {
    if (!f->is_in_domain()) continue;
    Tri t{remap[f->vertex(0)->info().id], remap[f->vertex(1)->info().id], remap[f->vertex(2)->info().id]};
    std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
    tri.push_back(t);
  }
  std::sort(tri.begin(), tri.end());
  required_vertex.resize(pb.required_slot.size());
  for (size_t i = 0; i < pb.required_slot.size(); ++i) {
    const auto v = slot[pb.required_slot[i]];
    if (v == CDT::Vertex_handle()) throw GeometryError("required point " + std::to_string(i) + " got no vertex");
    required_vertex[i] = remap[v->info().id];
  }
}

}  // namespace

std::vector<Vec2> preset_outline(const std::string& name) {
  double w = 0, h = 0;
  if (name == "A3") {
    w = 0.297, h = 0.42;
  } else if (name == "A4") {
    w = 0.21, h = 0.297;
  } else if (name == "A5") {
    w = 0.148, h = 0.21;
  } else if (name == "A6") {
    w = 0.105, h = 0.148;
  } else {
    throw GeometryError("unknown sheet preset \"" + name + "\" (known: A3, A4, A5, A6)");
  }
  return {Vec2(0, 0), Vec2(w, 0), Vec2(w, h), Vec2(0, h)};
}

std::string segment_problem(const MeshRequest& request, size_t k) {
  const auto& points = request.required_points;
  const auto& [a, b] = request.required_segments[k];
  const auto valid = [&](int32_t i) { return i >= 0 && size_t(i) < points.size(); };
  if (!valid(a) || !valid(b)) return "its points are not required points";
  const Vec2 p = points[size_t(a)], q = points[size_t(b)];
  if (!p.allFinite() || !q.allFinite()) return "a point is not finite";
  if (p == q) return "its two points are the same";
  // Inside: it crosses no outline edge, and points along it are on the sheet (which catches a segment
  // that leaves through outline vertices, crossing no edge properly).
  const auto& outline = request.outline;
  const auto crosses = [](const Vec2& a0, const Vec2& a1, const Vec2& b0, const Vec2& b1) {
    return orient(a0, a1, b0) * orient(a0, a1, b1) < 0 && orient(b0, b1, a0) * orient(b0, b1, a1) < 0;
  };
  for (size_t e = 0; e < outline.size(); ++e)
    if (crosses(p, q, outline[e], outline[(e + 1) % outline.size()])) return "it leaves the outline";
  constexpr int kSamples = 16;
  for (int i = 1; i < kSamples; ++i)
    if (!point_on_sheet(outline, p + (q - p) * (double(i) / kSamples))) return "it leaves the outline";
  for (size_t j = 0; j < k; ++j) {
    const auto& [c, d] = request.required_segments[j];
    if (valid(c) && valid(d) && crosses(p, q, points[size_t(c)], points[size_t(d)]))
      return "it crosses required segment " + std::to_string(j);
  }
  return "";
}

std::string outline_problem(const std::vector<Vec2>& outline) {
  const size_t n = outline.size();
  if (n < 3) return "outline has " + std::to_string(n) + " vertices, needs at least 3";
  // Bounded so the sweep's O(n²) worst case stays affordable.
  if (n > 100000) return "outline has " + std::to_string(n) + " vertices, at most 100000 are supported";
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(outline[i].x()) || !std::isfinite(outline[i].y()))
      return "outline vertex " + std::to_string(i) + " has a non-finite coordinate";
  }
  for (size_t i = 0; i < n; ++i) {
    const size_t j = (i + 1) % n;
    if (outline[i] == outline[j]) {
      if (j == 0)
        return "outline's last vertex repeats its first " + fmt_point(outline[0]) +
               " (the polygon closes itself; do not repeat the first vertex)";
      return "outline vertices " + std::to_string(i) + " and " + std::to_string(j) + " are the same point " +
             fmt_point(outline[i]);
    }
  }
  bool all_collinear = true;
  for (size_t i = 2; i < n && all_collinear; ++i) all_collinear = orient(outline[0], outline[1], outline[i]) == 0;
  if (all_collinear) return "outline vertices are all collinear (zero area)";
  const auto [e, f] = find_self_intersection(outline);
  if (e >= 0)
    return "outline is not simple: " + fmt_edge(outline, size_t(e)) + " touches " + fmt_edge(outline, size_t(f));
  const double area = signed_area(outline);
  if (area < 0) return "outline is clockwise (signed area " + std::to_string(area) + "); list it counter-clockwise";
  if (!(area > 0)) return "outline has zero area";
  return "";
}

bool point_in_polygon(const std::vector<Vec2>& polygon, const Vec2& p, double tolerance) {
  const size_t n = polygon.size();
  if (n < 3) return false;
  bool inside = false;
  const double tol2 = tolerance * tolerance;
  for (size_t i = 0, j = n - 1; i < n; j = i++) {
    const Vec2& a = polygon[j];
    const Vec2& b = polygon[i];
    // On the boundary (within tolerance) counts as inside: fingers are often put on the sheet's edge.
    const Vec2 ab = b - a;
    const double len2 = ab.squaredNorm();
    const double t = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
    if ((a + t * ab - p).squaredNorm() <= tol2) return true;
    if ((a.y() > p.y()) != (b.y() > p.y())) {
      const double x = a.x() + (p.y() - a.y()) / (b.y() - a.y()) * (b.x() - a.x());
      if (p.x() < x) inside = !inside;
    }
  }
  return inside;
}

double outline_snap_distance(const std::vector<Vec2>& outline) {
  if (outline.empty()) return 0;
  Vec2 lo = outline[0], hi = outline[0];
  for (const Vec2& p : outline) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  return 1e-10 * (hi - lo).norm();
}

bool point_on_sheet(const std::vector<Vec2>& outline, const Vec2& p) {
  return point_in_polygon(outline, p, outline_snap_distance(outline));
}

int64_t max_mesh_triangles(int64_t target, int64_t points) {
  return std::max<int64_t>({4 * target, 4 * points, 10'000});
}

double min_quality_triangles(const std::vector<Vec2>& outline, double min_angle_deg) {
  const size_t n = outline.size();
  if (n < 3) return 0;
  double perimeter = 0;
  for (size_t i = 0; i < n; ++i) perimeter += (outline[(i + 1) % n] - outline[i]).norm();
  const double area = std::abs(signed_area(outline));
  if (!(area > 0) || !(min_angle_deg > 0)) return 0;
  return std::tan(min_angle_deg * std::numbers::pi / 180) * perimeter * perimeter / (36 * area);
}

namespace {
std::string too_fine_message(int64_t target, double min_angle_deg, int64_t limit) {
  return "outline has features far finer than a mesh of " + std::to_string(target) +
         " triangles (a narrow strip or a short edge): meshing it at " + std::to_string(int(min_angle_deg)) +
         " deg needs more than " + std::to_string(limit) + " triangles";
}
}  // namespace

void mesh_outline(const MeshRequest& request, std::vector<Vec2>& rest, std::vector<Tri>& tri,
                  std::vector<int32_t>& required_vertex) {
  const std::string problem = outline_problem(request.outline);
  if (!problem.empty()) throw GeometryError(problem);
  if (request.target_triangles < 2 || request.target_triangles > 2'000'000)
    throw GeometryError("target triangle count " + std::to_string(request.target_triangles) +
                        " is outside [2, 2000000]");
  // Above ~30° Delaunay refinement is not guaranteed to terminate.
  if (!(request.min_angle_deg >= 0 && request.min_angle_deg <= 30))
    throw GeometryError("minimum angle " + std::to_string(request.min_angle_deg) + " deg is outside [0, 30]");
  if (!std::isfinite(request.rotation_deg))
    throw GeometryError("mesh rotation is not finite");

  for (size_t k = 0; k < request.required_segments.size(); ++k) {
    const std::string why = segment_problem(request, k);
    if (!why.empty()) throw GeometryError("required segment " + std::to_string(k) + ": " + why);
  }
  const Problem prob = prepare(request);
  // A hair above the requested bound: restoring exact input coordinates after meshing in a rotated frame
  // moves vertices by ~1e-16 relative, which must not push an angle below the bound.
  const double angle = request.min_angle_deg > 0 ? std::min(request.min_angle_deg + 0.1, 30.0) : 0.0;
  const double sin_a = std::sin(angle * std::numbers::pi / 180);
  const double aspect_bound = sin_a * sin_a;

  const double target = request.target_triangles;
  // The most triangles a mesh of this request may have: a few times what was asked, or what the outline's
  // own vertices need, never below a small sheet's worth. A triangulated polygon has T = 2 V_inside +
  // V_boundary − 2 ≥ V − 2 triangles, so refinement is given up past max_triangles + 2 vertices.
  const long max_triangles = max_mesh_triangles(request.target_triangles, int64_t(prob.exact.size()));
  if (min_quality_triangles(request.outline, request.min_angle_deg) > double(max_triangles))
    throw GeometryError(too_fine_message(request.target_triangles, request.min_angle_deg, max_triangles));
  // Delaunay refinement with edge bound S yields triangles of about 0.2 S² on average (calibrated on
  // rectangles); the loop below corrects for the boundary and the required points.
  double size = std::min(std::sqrt(prob.area / (0.2 * target)), prob.diameter);
  double too_fine = 0, too_coarse = 0;  // bracket on `size`: counts above / below the target
  std::unique_ptr<CDT> best;
  long best_count = -1;
  for (int round = 0; round < 12; ++round) {
    auto cdt = std::make_unique<CDT>();
    long count = refine(prob, request, aspect_bound, size, max_triangles + 2, *cdt);
    const bool over = count < 0 || count > max_triangles;
    if (over) {
      cdt.reset();
      count = 2 * max_triangles;  // at least: steer the size bound coarser
    } else if (best_count < 0 || std::abs(count - target) < std::abs(best_count - target)) {
      best_count = count;
      best = std::move(cdt);
    }
    // Aim inside ±8% so the ±20% contract holds with margin; stop early when close enough.
    if (std::abs(count - target) <= 0.08 * target) break;
    if (count > target) {
      if (size >= prob.diameter) break;  // the size bound no longer acts: no coarser mesh exists
      too_fine = std::max(too_fine, size);
    } else {
      too_coarse = too_coarse > 0 ? std::min(too_coarse, size) : size;
    }
    double next = size * std::sqrt(double(count) / target);
    if (too_fine > 0 && too_coarse > 0 && !(next > too_fine && next < too_coarse))
      next = std::sqrt(too_fine * too_coarse);
    if (too_coarse > 0 && too_fine > 0 && too_coarse / too_fine < 1 + 1e-6) break;  // a step in count
    size = std::min(next, prob.diameter);
  }
  if (!best) throw GeometryError(too_fine_message(request.target_triangles, request.min_angle_deg, max_triangles));
  extract(prob, *best, rest, tri, required_vertex);
}

}  // namespace pt
