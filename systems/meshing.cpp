// Meshing of the sheet's outline (DESIGN §2, §4): validation of the outline polygon, presets, and the
// CGAL constrained Delaunay refinement. CGAL stays inside this file so no other translation unit pays
// for its headers.
#include "systems/meshing.hpp"

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Delaunay_mesh_face_base_2.h>
#include <CGAL/Delaunay_mesh_size_criteria_2.h>
#include <CGAL/Delaunay_mesh_vertex_base_2.h>
#include <CGAL/Delaunay_mesher_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <unordered_map>

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

void mesh_outline(const MeshRequest& request, std::vector<Vec2>& rest, std::vector<Tri>& tri,
                  std::vector<int32_t>& required_vertex) {
  throw GeometryError("mesh_outline: not implemented yet");
}

}  // namespace pt
