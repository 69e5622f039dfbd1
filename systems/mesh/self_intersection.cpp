#include "systems/mesh/self_intersection.hpp"

#include <CGAL/Box_intersection_d/Box_with_handle_d.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/box_intersection_d.h>
#include <CGAL/intersections.h>

namespace pt {

namespace {
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Triangle = Kernel::Triangle_3;
using Box = CGAL::Box_intersection_d::Box_with_info_d<double, 3, int32_t>;
}  // namespace

SelfIntersectionCount count_self_intersections(const std::vector<Vec3>& x, const std::vector<Tri>& tris) {
  SelfIntersectionCount count;
  std::vector<Triangle> triangles(tris.size());
  std::vector<Box> boxes;
  boxes.reserve(tris.size());
  for (size_t t = 0; t < tris.size(); ++t) {
    const Point a(x[tris[t][0]].x(), x[tris[t][0]].y(), x[tris[t][0]].z());
    const Point b(x[tris[t][1]].x(), x[tris[t][1]].y(), x[tris[t][1]].z());
    const Point c(x[tris[t][2]].x(), x[tris[t][2]].y(), x[tris[t][2]].z());
    if (CGAL::collinear(a, b, c)) {
      count.degenerate += 1;
      continue;
    }
    triangles[t] = Triangle(a, b, c);
    boxes.emplace_back(triangles[t].bbox(), static_cast<int32_t>(t));
  }
  auto adjacent = [&](int32_t s, int32_t t) {
    for (int32_t a : tris[s])
      for (int32_t b : tris[t])
        if (a == b || x[a] == x[b]) return true;
    return false;
  };
  CGAL::box_self_intersection_d(boxes.begin(), boxes.end(), [&](const Box& p, const Box& q) {
    if (adjacent(p.info(), q.info())) return;
    count.candidates += 1;
    if (CGAL::do_intersect(triangles[p.info()], triangles[q.info()])) count.intersecting += 1;
  });
  return count;
}

}  // namespace pt
