// libFuzzer target (issue 9): random sequences of tear cuts on random outlines, checking the mesh
// invariants (docs/architecture.md "Data and its invariants") after every cut. The bytes decode into
//   - an outline: a grid sheet (tests/test_meshes.hpp) of random size, resolution and jitter, or
//     mesh_outline of a random simple (star-shaped, counter-clockwise) polygon;
//   - a sequence of cuts: continue an active tip or start a new tear at a boundary vertex, an angle
//     (absolute for a new tear, a turn for a tip) and a length (log-uniform, 1e-4 to 1 sheet size).
// cut_tear_segment is called on each; after each: check_mesh_invariants(sheet, area) empty, every rest and
// 3D position finite, 3D positions of new vertices the affine image of their pattern position (barycentric
// interpolation of an affine map), tips on boundary vertices. Any violation aborts.
#include "systems/mesh/meshing.hpp"
#include "systems/mesh/remeshing.hpp"
#include "systems/common/topology.hpp"
#include "tests/test_meshes.hpp"

#include <fuzzer/FuzzedDataProvider.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

using namespace pt;

namespace {

Vec3 affine3(const Vec2& r) { return Vec3(0.9 * r.x() + 0.1 * r.y() + 0.01, 0.2 * r.x() + 0.8 * r.y(), 0.3 * r.x() - 0.4 * r.y()); }

std::string trace;  // what was done so far, printed with a finding

[[noreturn]] void finding(const std::string& what) {
  std::fprintf(stderr, "fuzz_remesher: %s\n--- sequence:\n%s", what.c_str(), trace.c_str());
  std::abort();
}

bool build_sheet(FuzzedDataProvider& in, Sheet& s) {
  const int kind = in.ConsumeIntegralInRange<int>(0, 1);
  if (kind == 0) {
    const double w = in.ConsumeFloatingPointInRange<double>(0.01, 1.0);
    const double h = in.ConsumeFloatingPointInRange<double>(0.01, 1.0);
    const int nx = in.ConsumeIntegralInRange<int>(1, 14), ny = in.ConsumeIntegralInRange<int>(1, 14);
    const double jitter = in.ConsumeFloatingPointInRange<double>(0.0, 0.45);
    const uint32_t seed = in.ConsumeIntegral<uint32_t>();
    s = test::grid_sheet(w, h, nx, ny, jitter, seed);
    std::ostringstream o;
    o.precision(17);
    o << "grid_sheet(" << w << ", " << h << ", " << nx << ", " << ny << ", " << jitter << ", " << seed << ")\n";
    trace += o.str();
  } else {
    // Star-shaped polygon around the origin: increasing angles, radii in [0.2, 1] x size: simple and CCW.
    const int n = in.ConsumeIntegralInRange<int>(3, 12);
    const double size = in.ConsumeFloatingPointInRange<double>(0.02, 0.5);
    std::vector<double> ang(n);
    for (int i = 0; i < n; ++i) ang[i] = (i + in.ConsumeFloatingPointInRange<double>(0.05, 0.95)) * 2 * std::numbers::pi / n;
    MeshRequest req;
    std::ostringstream o;
    o.precision(17);
    o << "mesh_outline({";
    for (int i = 0; i < n; ++i) {
      const double r = size * in.ConsumeFloatingPointInRange<double>(0.2, 1.0);
      req.outline.push_back(Vec2(r * std::cos(ang[i]), r * std::sin(ang[i])));
      o << "{" << req.outline.back().x() << ", " << req.outline.back().y() << "}, ";
    }
    req.target_triangles = in.ConsumeIntegralInRange<int>(8, 300);
    req.seed = in.ConsumeIntegralInRange<uint64_t>(0, 7);
    req.rotation_deg = in.ConsumeFloatingPointInRange<double>(0, 90);
    o << "}, triangles " << req.target_triangles << ", seed " << req.seed << ", rotation " << req.rotation_deg << ")\n";
    trace += o.str();
    std::vector<Vec2> rest;
    std::vector<Tri> tri;
    std::vector<int32_t> required;
    try {
      mesh_outline(req, rest, tri, required);
    } catch (const GeometryError&) {
      return false;  // e.g. a near-degenerate polygon: the mesher refuses it clearly
    }
    s = Sheet{};
    s.verts.resize(static_cast<int32_t>(rest.size()));
    for (size_t i = 0; i < rest.size(); ++i) s.verts.rest[i] = rest[i];
    s.tris.resize(static_cast<int32_t>(tri.size()));
    s.tris.tri = tri;
    refresh_after_topology_change(s);
  }
  for (int32_t v = 0; v < s.verts.size(); ++v) s.verts.x[v] = affine3(s.verts.rest[v]);
  return true;
}

void check(const Sheet& s, double area, const CutResult& res) {
  if (std::string p = check_mesh_invariants(s, area); !p.empty()) finding("invariant: " + p);
  for (int32_t v = 0; v < s.verts.size(); ++v) {
    if (!s.verts.rest[v].allFinite() || !s.verts.x[v].allFinite()) finding("non-finite position at vertex " + std::to_string(v));
    const double err = (s.verts.x[v] - affine3(s.verts.rest[v])).norm();
    if (err > 1e-9) finding("3D position of vertex " + std::to_string(v) + " is not interpolated (error " + std::to_string(err) + ")");
  }
  if (res.cut && !res.reached_boundary) {
    if (res.tip_vertex < 0 || res.tip_vertex >= s.verts.size()) finding("tip vertex out of range");
    if (!(s.verts.flags[res.tip_vertex] & kBoundary)) finding("tip vertex not on the boundary");
  }
  for (const Tip& t : s.tips)
    if (t.vertex < 0 || t.vertex >= s.verts.size()) finding("a tip points outside the vertex arrays");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  FuzzedDataProvider in(data, size);
  trace.clear();
  Sheet s;
  if (!build_sheet(in, s)) return 0;
  if (std::string p = check_mesh_invariants(s); !p.empty()) return 0;  // not a remesher finding
  const double area = total_rest_area(s.tris);
  const double scale = std::sqrt(area);
  RemeshParams params;
  if (in.ConsumeBool()) {
    params.split_angle = in.ConsumeFloatingPointInRange<double>(0.0, 1.0);
    params.snap_fraction = in.ConsumeFloatingPointInRange<double>(0.0, 0.45);
    params.min_angle_deg = in.ConsumeFloatingPointInRange<double>(0.0, 20.0);
  }
  int32_t next_tear = 0;
  for (int cut = 0; cut < 40 && in.remaining_bytes() > 0; ++cut) {
    const bool cont = in.ConsumeBool() && !s.tips.empty();
    const uint16_t index = in.ConsumeIntegral<uint16_t>();
    const double angle = in.ConsumeFloatingPointInRange<double>(-std::numbers::pi, std::numbers::pi);
    const double length = scale * std::pow(10.0, in.ConsumeFloatingPointInRange<double>(-4.0, 0.0));
    int32_t p = -1, tip_index = -1, tear = -1;
    Vec2 dir, prev = Vec2::Zero();
    if (cont) {
      tip_index = index % static_cast<int32_t>(s.tips.size());
      const Tip& t = s.tips[tip_index];
      p = t.vertex;
      tear = t.tear;
      prev = t.direction;
      const Vec2 base = prev.squaredNorm() > 0 ? prev : Vec2(1, 0);
      const double a = std::atan2(base.y(), base.x()) + 0.5 * angle;  // turns up to ±90°
      dir = Vec2(std::cos(a), std::sin(a));
    } else {
      std::vector<int32_t> starts;
      for (int32_t v = 0; v < s.verts.size(); ++v)
        if ((s.verts.flags[v] & kBoundary) && !(s.verts.flags[v] & kTip)) starts.push_back(v);
      if (starts.empty()) break;
      p = starts[index % starts.size()];
      tear = next_tear;
      dir = Vec2(std::cos(angle), std::sin(angle));
    }
    const Vec2 from = s.verts.rest[p];
    const Vec2 next = from + length * dir;
    {
      std::ostringstream o;
      o.precision(17);
      o << "cut " << cut << ": p " << p << " (" << from.x() << ", " << from.y() << ") -> (" << next.x() << ", "
        << next.y() << ") prev (" << prev.x() << ", " << prev.y() << ") tear " << tear << (cont ? " (tip)" : " (new)") << "\n";
      trace += o.str();
    }
    const CutResult res = cut_tear_segment(p, next, prev, tear, params, s);
    check(s, area, res);
    if (!res.cut) continue;
    const Vec2 d = res.end - from;
    const Vec2 u = d.squaredNorm() > 0 ? Vec2(d.normalized()) : dir;
    if (cont) {
      if (res.reached_boundary) s.tips.erase(s.tips.begin() + tip_index);
      else s.tips[tip_index] = Tip{res.tip_vertex, tear, u};
    } else {
      ++next_tear;
      if (!res.reached_boundary) s.tips.push_back(Tip{res.tip_vertex, tear, u});
    }
    check(s, area, res);
  }
  return 0;
}
