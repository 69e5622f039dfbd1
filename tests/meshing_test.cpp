// Tests of systems/meshing: outline validation, presets, and the quality mesher.
#include "systems/meshing.hpp"
#include "systems/topology.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

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

}  // namespace
}  // namespace pt
