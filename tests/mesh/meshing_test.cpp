// Tests of systems/mesh/meshing: outline validation, presets, and the quality mesher.
#include "systems/mesh/meshing.hpp"
#include "systems/common/topology.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

namespace pt {
namespace {

std::vector<Vec2> poly(std::initializer_list<std::pair<double, double>> pts) {
  std::vector<Vec2> out;
  for (auto [u, v] : pts) out.emplace_back(u, v);
  return out;
}

TEST(Meshing, PresetsAreCcwRectangles) {
  const auto a4 = preset_outline("A4");
  ASSERT_EQ(a4.size(), 4u);
  EXPECT_EQ(a4[2], Vec2(0.21, 0.297));
  EXPECT_EQ(preset_outline("A3")[2], Vec2(0.297, 0.42));
  EXPECT_EQ(preset_outline("A5")[2], Vec2(0.148, 0.21));
  EXPECT_EQ(preset_outline("A6")[2], Vec2(0.105, 0.148));
  for (const char* name : {"A3", "A4", "A5", "A6"}) EXPECT_EQ(outline_problem(preset_outline(name)), "") << name;
  EXPECT_THROW(preset_outline("Letter"), GeometryError);
}

TEST(Meshing, OutlineProblemsAreNamed) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(outline_problem(poly({{0, 0}, {1, 0}})).find("needs at least 3"), std::string::npos);
  EXPECT_NE(outline_problem(poly({{0, 0}, {1, 0}, {1, 1}, {0, 1}, {0, 0}})).find("repeats"), std::string::npos);
  EXPECT_NE(outline_problem(poly({{0, 0}, {1, 0}, {1, 0}, {0, 1}})).find("same point"), std::string::npos);
  EXPECT_NE(outline_problem(poly({{0, 0}, {1, 0}, {nan, 1}})).find("non-finite"), std::string::npos);
  EXPECT_NE(outline_problem(poly({{0, 0}, {0, 1}, {1, 1}, {1, 0}})).find("clockwise"), std::string::npos);
  const std::string bowtie = outline_problem(poly({{0, 0}, {1, 1}, {1, 0}, {0, 1}}));
  EXPECT_NE(bowtie.find("not simple"), std::string::npos) << bowtie;
  EXPECT_NE(bowtie.find("edge 0"), std::string::npos) << bowtie;
  EXPECT_NE(bowtie.find("edge 2"), std::string::npos) << bowtie;
  EXPECT_NE(outline_problem(poly({{0, 0}, {1, 0}, {2, 0}})).find("collinear"), std::string::npos);
  // A spike that folds back on itself.
  EXPECT_NE(outline_problem(poly({{0, 0}, {2, 0}, {1, 0}, {1, 1}})), "");
  // A vertex touching another edge.
  EXPECT_NE(outline_problem(poly({{0, 0}, {2, 0}, {2, 2}, {1, 0}, {0, 2}})), "");
  // Straight-through collinear vertices are fine.
  EXPECT_EQ(outline_problem(poly({{0, 0}, {1, 0}, {2, 0}, {2, 1}, {0, 1}})), "");
  EXPECT_NE(outline_problem(std::vector<Vec2>(100001, Vec2::Zero())).find("at most"), std::string::npos);
}

TEST(Meshing, LargeOutlineValidatesQuickly) {
  // A 100000-gon circle: the sweep must not go quadratic on an ordinary shape.
  std::vector<Vec2> circle;
  const int n = 100000;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n;
    circle.emplace_back(std::cos(a), std::sin(a));
  }
  EXPECT_EQ(outline_problem(circle), "");
}

TEST(Meshing, PointInPolygon) {
  const auto notch = poly({{0, 0}, {0.148, 0}, {0.148, 0.21}, {0.078, 0.21}, {0.074, 0.19}, {0.070, 0.21}, {0, 0.21}});
  EXPECT_TRUE(point_in_polygon(notch, Vec2(0.05, 0.1)));
  EXPECT_TRUE(point_in_polygon(notch, Vec2(0.0, 0.1)));    // on an edge
  EXPECT_TRUE(point_in_polygon(notch, Vec2(0.148, 0.21))); // a corner
  EXPECT_TRUE(point_in_polygon(notch, Vec2(0.074, 0.19))); // notch tip
  EXPECT_FALSE(point_in_polygon(notch, Vec2(0.074, 0.20))); // inside the notch
  EXPECT_FALSE(point_in_polygon(notch, Vec2(-0.01, 0.1)));
  EXPECT_FALSE(point_in_polygon(notch, Vec2(0.2, 0.21)));
}


double shoelace(const std::vector<Vec2>& p) {
  double a = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    const Vec2& u = p[i];
    const Vec2& w = p[(i + 1) % p.size()];
    a += u.x() * w.y() - u.y() * w.x();
  }
  return 0.5 * a;
}

double tri_area(const std::vector<Vec2>& r, const Tri& t) {
  const Vec2 a = r[t[1]] - r[t[0]], b = r[t[2]] - r[t[0]];
  return 0.5 * (a.x() * b.y() - a.y() * b.x());
}

double min_angle_deg(const std::vector<Vec2>& r, const Tri& t) {
  double m = 180;
  for (int k = 0; k < 3; ++k) {
    const Vec2 a = r[t[(k + 1) % 3]] - r[t[k]], b = r[t[(k + 2) % 3]] - r[t[k]];
    m = std::min(m, std::acos(std::clamp(a.dot(b) / (a.norm() * b.norm()), -1.0, 1.0)) * 180 / M_PI);
  }
  return m;
}

struct Mesh {
  std::vector<Vec2> rest;
  std::vector<Tri> tri;
  std::vector<int32_t> required;
};

Mesh run(const MeshRequest& rq) {
  Mesh m;
  mesh_outline(rq, m.rest, m.tri, m.required);
  return m;
}

// Every contract property of one mesh; `context` names the case in failure messages.
void expect_valid(const MeshRequest& rq, const Mesh& m, const std::string& context) {
  SCOPED_TRACE(context);
  const double target = rq.target_triangles;
  EXPECT_GE(double(m.tri.size()), 0.8 * target);
  EXPECT_LE(double(m.tri.size()), 1.2 * target);
  // Outline corners sharper than the bound are exempt (the mesher cannot fix an input angle).
  std::vector<char> sharp(m.rest.size(), 0);
  const auto& o = rq.outline;
  for (size_t i = 0; i < o.size(); ++i) {
    const Vec2 a = o[(i + o.size() - 1) % o.size()] - o[i], b = o[(i + 1) % o.size()] - o[i];
    const double ang = std::acos(std::clamp(a.dot(b) / (a.norm() * b.norm()), -1.0, 1.0)) * 180 / M_PI;
    if (ang < rq.min_angle_deg)
      for (size_t v = 0; v < m.rest.size(); ++v) sharp[v] |= m.rest[v] == o[i];
  }
  double area = 0, worst = 180;
  for (const Tri& t : m.tri) {
    const double a = tri_area(m.rest, t);
    ASSERT_GT(a, 0) << "triangle not counter-clockwise";
    area += a;
    if (!sharp[t[0]] && !sharp[t[1]] && !sharp[t[2]]) worst = std::min(worst, min_angle_deg(m.rest, t));
  }
  EXPECT_GE(worst, rq.min_angle_deg);
  EXPECT_NEAR(area, shoelace(rq.outline), 1e-9 * shoelace(rq.outline));
  ASSERT_EQ(m.required.size(), rq.required_points.size());
  for (size_t i = 0; i < rq.required_points.size(); ++i) {
    ASSERT_GE(m.required[i], 0);
    ASSERT_LT(m.required[i], int32_t(m.rest.size()));
    EXPECT_EQ(m.rest[m.required[i]], rq.required_points[i]) << "required point " << i;
  }
  for (const Vec2& p : rq.outline)
    EXPECT_TRUE(std::find(m.rest.begin(), m.rest.end(), p) != m.rest.end()) << "outline vertex missing";
  for (const Vec2& p : m.rest) EXPECT_TRUE(point_in_polygon(rq.outline, p, 1e-12)) << p.transpose();

  Sheet sheet;
  sheet.verts.resize(int32_t(m.rest.size()));
  sheet.verts.rest = m.rest;
  for (size_t v = 0; v < m.rest.size(); ++v) sheet.verts.x[v] = Vec3(m.rest[v].x(), m.rest[v].y(), 0);
  sheet.tris.resize(int32_t(m.tri.size()));
  sheet.tris.tri = m.tri;
  refresh_after_topology_change(sheet);
  EXPECT_EQ(check_mesh_invariants(sheet, shoelace(rq.outline)), "");
  EXPECT_EQ(sheet.topo.piece_count, 1);
}

std::vector<Vec2> notch_a5() {
  return poly({{0, 0}, {0.148, 0}, {0.148, 0.21}, {0.078, 0.21}, {0.074, 0.19}, {0.070, 0.21}, {0, 0.21}});
}

TEST(Meshing, CountAngleAreaInvariantsOnA4) {
  for (int target : {100, 400, 1000, 10000}) {
    MeshRequest rq;
    rq.outline = preset_outline("A4");
    rq.target_triangles = target;
    expect_valid(rq, run(rq), "A4 target " + std::to_string(target));
  }
}

TEST(Meshing, RequiredPointsAreExactVertices) {
  MeshRequest rq;
  rq.outline = preset_outline("A4");
  rq.target_triangles = 400;
  // Interior, on an edge (splits it), at a corner, a duplicate, and two close ones.
  rq.required_points = {Vec2(0.064, 0.205), Vec2(0.1, 0.0), Vec2(0.21, 0.297), Vec2(0.064, 0.205),
                        Vec2(0.0123456789, 0.1987654321), Vec2(0.0133456789, 0.1987654321), Vec2(0.0, 0.15)};
  const Mesh m = run(rq);
  expect_valid(rq, m, "required points");
  EXPECT_EQ(m.required[0], m.required[3]);
}

TEST(Meshing, NotchedOutline) {
  MeshRequest rq;
  rq.outline = notch_a5();
  rq.required_points = {Vec2(0.064, 0.205), Vec2(0.084, 0.205), Vec2(0.074, 0.19)};
  for (int target : {100, 400, 2000}) {
    rq.target_triangles = target;
    expect_valid(rq, run(rq), "notch target " + std::to_string(target));
  }
}

TEST(Meshing, SharpInputAngleIsExempt) {
  MeshRequest rq;
  rq.outline = poly({{0, 0}, {0.2, 0}, {0.2, 0.1}, {0.1, 0.1}, {0.0, 0.02}});  // ~11° corner at the origin
  rq.target_triangles = 300;
  expect_valid(rq, run(rq), "sharp corner");
}

TEST(Meshing, DeterministicAndCompact) {
  MeshRequest rq;
  rq.outline = notch_a5();
  rq.target_triangles = 500;
  rq.seed = 7;
  rq.rotation_deg = 17;
  const Mesh a = run(rq), b = run(rq);
  EXPECT_EQ(a.tri, b.tri);
  EXPECT_EQ(a.rest, b.rest);
  std::vector<char> used(a.rest.size(), 0);
  for (const Tri& t : a.tri)
    for (int32_t v : t) used[v] = 1;
  EXPECT_EQ(std::count(used.begin(), used.end(), 1), long(a.rest.size()));
}

TEST(Meshing, SeedsAndRotationsGiveDifferentMeshes) {
  MeshRequest rq;
  rq.outline = preset_outline("A4");
  rq.target_triangles = 1000;
  rq.required_points = {Vec2(0.064, 0.205)};
  std::vector<std::vector<Tri>> seen;
  std::vector<std::vector<Vec2>> seen_rest;
  for (auto [seed, rot] : std::vector<std::pair<uint64_t, double>>{{0, 0}, {1, 0}, {2, 0}, {0, 30}, {0, 45}, {3, 10}}) {
    rq.seed = seed;
    rq.rotation_deg = rot;
    const Mesh m = run(rq);
    expect_valid(rq, m, "seed " + std::to_string(seed) + " rotation " + std::to_string(rot));
    for (size_t k = 0; k < seen.size(); ++k) {
      EXPECT_NE(m.tri, seen[k]);
      EXPECT_NE(m.rest, seen_rest[k]);
      // Visibly different: most triangles (compared by their corner positions) are not shared.
      auto keys = [](const std::vector<Vec2>& r, const std::vector<Tri>& ts) {
        std::set<std::array<double, 6>> out;
        for (const Tri& t : ts) out.insert({r[t[0]].x(), r[t[0]].y(), r[t[1]].x(), r[t[1]].y(), r[t[2]].x(), r[t[2]].y()});
        return out;
      };
      const auto a = keys(m.rest, m.tri), b = keys(seen_rest[k], seen[k]);
      size_t shared = 0;
      for (const auto& key : a) shared += b.count(key);
      EXPECT_LT(double(shared), 0.5 * double(a.size())) << "mesh " << k;
    }
    seen.push_back(m.tri);
    seen_rest.push_back(m.rest);
  }
}

// What mesh_outline throws for `rq`, or "<no throw>".
std::string mesh_error(const MeshRequest& rq) {
  try {
    run(rq);
  } catch (const GeometryError& e) {
    return e.what();
  }
  return "<no throw>";
}

TEST(Meshing, BadInputsThrow) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  MeshRequest rq;
  rq.outline = poly({{0, 0}, {1, 1}, {1, 0}, {0, 1}});
  EXPECT_NE(mesh_error(rq).find("not simple"), std::string::npos);
  rq.outline = poly({{0, 0}, {0, 1}, {1, 1}, {1, 0}});
  EXPECT_NE(mesh_error(rq).find("clockwise"), std::string::npos);
  rq.outline = poly({{0, 0}, {1, 0}});
  EXPECT_NE(mesh_error(rq).find("at least 3"), std::string::npos);
  rq.outline = poly({{0, 0}, {1, 0}, {1, 0}, {0, 1}});
  EXPECT_NE(mesh_error(rq).find("same point"), std::string::npos);
  rq.outline = poly({{0, 0}, {1, 0}, {1, nan}, {0, 1}});
  EXPECT_NE(mesh_error(rq).find("non-finite"), std::string::npos);
  rq.outline = notch_a5();
  rq.required_points = {Vec2(0.074, 0.2)};  // in the notch
  EXPECT_NE(mesh_error(rq).find("point (0.074, 0.2) is outside the outline"), std::string::npos) << mesh_error(rq);
  rq.required_points = {Vec2(0.3, 0.1)};
  EXPECT_NE(mesh_error(rq).find("outside the outline"), std::string::npos);
  rq.required_points.clear();
  rq.target_triangles = 1;
  EXPECT_NE(mesh_error(rq).find("target"), std::string::npos);
  rq.target_triangles = 2'000'001;
  EXPECT_NE(mesh_error(rq).find("target"), std::string::npos);
}

// The mesh edges lying on [a, b] (both ends on it within 1e-12 m), summed: a segment that is a chain of
// edges gives its own length; one that triangles straddle gives less.
double edge_length_on(const Mesh& m, const Vec2& a, const Vec2& b) {
  std::set<std::pair<int32_t, int32_t>> seen;
  double total = 0;
  const Vec2 d = (b - a).normalized();
  auto on = [&](const Vec2& p) {
    const double t = (p - a).dot(d);
    return t >= -1e-12 && t <= (b - a).norm() + 1e-12 && std::abs(d.x() * (p - a).y() - d.y() * (p - a).x()) < 1e-12;
  };
  for (const Tri& t : m.tri)
    for (int k = 0; k < 3; ++k) {
      const int32_t i = std::min(t[k], t[(k + 1) % 3]), j = std::max(t[k], t[(k + 1) % 3]);
      if (seen.insert({i, j}).second && on(m.rest[i]) && on(m.rest[j])) total += (m.rest[i] - m.rest[j]).norm();
    }
  return total;
}

TEST(Meshing, RequiredSegmentsBecomeChainsOfEdges) {
  // A hand's two fingers inside an A5 sheet and another hand's two fingers on its border and inside, on
  // several meshes and densities: each segment is covered by mesh edges end to end.
  for (const int target : {120, 500}) {
    for (const uint64_t seed : {uint64_t(0), uint64_t(1), uint64_t(2)}) {
      MeshRequest rq;
      rq.outline = preset_outline("A5");
      rq.target_triangles = target;
      rq.seed = seed;
      rq.rotation_deg = 17.0 * double(seed);
      rq.required_points = {Vec2(0.02, 0.08), Vec2(0.02, 0.13), Vec2(0.148, 0.1), Vec2(0.11, 0.17)};
      rq.required_segments = {{0, 1}, {2, 3}};
      const Mesh m = run(rq);
      expect_valid(rq, m, "segments");
      for (const auto& [a, b] : rq.required_segments) {
        const Vec2 p = rq.required_points[size_t(a)], q = rq.required_points[size_t(b)];
        EXPECT_NEAR(edge_length_on(m, p, q), (q - p).norm(), 1e-9) << target << " triangles, seed " << seed;
      }
      // Without the constraint the same mesh does not follow the slanted segment.
      rq.required_segments.clear();
      const Mesh free = run(rq);
      EXPECT_LT(edge_length_on(free, rq.required_points[2], rq.required_points[3]),
                0.99 * (rq.required_points[3] - rq.required_points[2]).norm())
          << target << " triangles, seed " << seed;
    }
  }
}

TEST(Meshing, SegmentProblemsAreNamed) {
  MeshRequest rq;
  rq.outline = notch_a5();
  rq.target_triangles = 200;
  // Across the notch, from one flank's side to the other.
  rq.required_points = {Vec2(0.064, 0.205), Vec2(0.084, 0.205), Vec2(0.074, 0.1), Vec2(0.074, 0.18),
                        Vec2(0.03, 0.15), Vec2(0.12, 0.15)};
  rq.required_segments = {{0, 1}};
  EXPECT_EQ(mesh_error(rq), "required segment 0: it leaves the outline");
  rq.required_segments = {{2, 3}};  // below the notch's apex: inside
  EXPECT_EQ(mesh_error(rq), "<no throw>");
  rq.required_segments = {{2, 3}, {4, 5}};
  EXPECT_EQ(mesh_error(rq), "required segment 1: it crosses required segment 0");
  rq.required_segments = {{4, 4}};
  EXPECT_EQ(mesh_error(rq), "required segment 0: its two points are the same");
  rq.required_segments = {{4, 9}};
  EXPECT_EQ(mesh_error(rq), "required segment 0: its points are not required points");
}

TEST(Meshing, TinyTargetGivesTwoTriangles) {
  MeshRequest rq;
  rq.outline = preset_outline("A4");
  rq.target_triangles = 2;
  const Mesh m = run(rq);
  EXPECT_EQ(m.tri.size(), 2u);
}

// Issue 27, item 5: a 0.3 m x 1e-7 m strip asked for 200 triangles meshed 4.19 M of them at a 20 deg bound
// (14 GB once simulated). The mesher now gives up at a few times the request, before it fills memory.
TEST(Meshing, OutlineFarThinnerThanTheMeshIsRefused) {
  MeshRequest rq;
  rq.outline = poly({{0, 0}, {0.3, 0}, {0.3, 1e-7}, {0, 1e-7}});
  rq.target_triangles = 200;
  std::string error;
  try {
    run(rq);
  } catch (const GeometryError& e) {
    error = e.what();
  }
  EXPECT_NE(error.find("features far finer than a mesh of 200 triangles"), std::string::npos) << error;
  EXPECT_NE(error.find("needs more than 10000 triangles"), std::string::npos) << error;
  // That strip is refused by the lower bound on any 20 deg mesh (121 000 triangles); a 0.3 m x 1e-5 m
  // strip passes the bound (1 213) and is given up while refining.
  EXPECT_NEAR(min_quality_triangles(rq.outline, 20), 121'000, 1'000);
  rq.outline = poly({{0, 0}, {0.3, 0}, {0.3, 1e-5}, {0, 1e-5}});
  EXPECT_LT(min_quality_triangles(rq.outline, 20), 10'000);
  error.clear();
  try {
    run(rq);
  } catch (const GeometryError& e) {
    error = e.what();
  }
  EXPECT_NE(error.find("needs more than 10000 triangles"), std::string::npos) << error;
  // A strip the mesh can follow is meshed as before: 0.3 m x 1 cm.
  rq.outline = poly({{0, 0}, {0.3, 0}, {0.3, 0.01}, {0, 0.01}});
  EXPECT_LT(min_quality_triangles(rq.outline, 20), 200);
  const Mesh m = run(rq);
  EXPECT_GT(m.tri.size(), 0u);
  EXPECT_LE(m.tri.size(), 10'000u);
}

}  // namespace
}  // namespace pt
