#include "systems/physics/self_contact.hpp"

#include "systems/common/pattern_geometry.hpp"
#include "systems/common/scoped_timer.hpp"

#include <embree3/rtcore.h>
#include <tbb/enumerable_thread_specific.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

namespace pt {

// ---- broad phase (Embree) ----------------------------------------------------------------------------

namespace {
struct Box {
  Vec3 lo, hi;
};
}  // namespace

struct SelfContactBroadPhase {
  RTCDevice device = nullptr;
  std::vector<RTCBounds> boxes;  // float, rounded outwards from the double boxes
  std::vector<Box> exact;        // the double boxes, for the exact test after Embree's
  std::vector<Box> grown;        // the boxes of the last query (below)
  // rtcCollide calls back from its worker threads (oneTBB's): each thread's pairs in its own list, no lock.
  tbb::enumerable_thread_specific<std::vector<std::array<int32_t, 2>>> found_by_thread;
  std::vector<std::array<int32_t, 2>> found;
  // Embree's scene, kept while the triangle count stays: a query then refits its BVH to the new boxes
  // (a rebuild per query was a third of a query's time).
  RTCScene scene = nullptr;
  RTCGeometry geometry = nullptr;
  size_t scene_triangles = 0;
  const std::vector<Tri>* tris = nullptr;  // of the current call: pairs sharing a corner are not kept
  std::vector<int32_t> first, fill, partner;  // the found pairs bucketed by their first triangle
  // The pairs of the last Embree query (s < t, ascending): every pair whose boxes around the corners at
  // `reference`, each grown by its triangle's `reach`, overlap. A later call whose boxes lie within those
  // (no corner farther than its triangle's reach less the margin from its reference, per axis; the same
  // triangles) only filters them: one BVH build and query for many substeps instead of two per substep.
  std::vector<std::array<int32_t, 2>> cached;
  std::vector<Tri> cached_tris;
  std::vector<Vec3> reference;
  std::vector<double> reach;   // m, per triangle
  std::vector<double> drift;   // scratch, per vertex
  double widest_margin = 0;    // the widest margin asked for so far: the reach's least
  std::vector<std::vector<std::array<int32_t, 2>>> kept_by_range;  // the filter's outputs (in_ranges)
  ~SelfContactBroadPhase() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
};

void SelfContactBroadPhaseDeleter::operator()(SelfContactBroadPhase* b) const { delete b; }

namespace {

void box_bounds(const RTCBoundsFunctionArguments* args) {
  const auto* b = static_cast<const SelfContactBroadPhase*>(args->geometryUserPtr);
  *args->bounds_o = b->boxes[args->primID];
}

bool share_a_corner(const Tri& a, const Tri& c) {
  bool shared = false;
  for (const int32_t u : a) shared = shared || u == c[0] || u == c[1] || u == c[2];
  return shared;
}

void collect_pairs(void* user, RTCCollision* collisions, unsigned int count) {
  auto* b = static_cast<SelfContactBroadPhase*>(user);
  std::vector<std::array<int32_t, 2>>& found = b->found_by_thread.local();
  for (unsigned int i = 0; i < count; ++i) {
    const auto s = static_cast<int32_t>(collisions[i].primID0), t = static_cast<int32_t>(collisions[i].primID1);
    if (s == t) continue;
    // Triangles that share a corner are neighbours, never a contact: most of a sheet's overlapping boxes
    // (each triangle's with its dozen neighbours'), whose sort took a sixth of a folded sheet's frame.
    if (!share_a_corner((*b->tris)[s], (*b->tris)[t])) found.push_back({std::min(s, t), std::max(s, t)});
  }
}

float down(double v) { return std::nextafter(static_cast<float>(v), -std::numeric_limits<float>::infinity()); }
float up(double v) { return std::nextafter(static_cast<float>(v), std::numeric_limits<float>::infinity()); }

Box path_box(const Tri& t, const std::vector<Vec3>& x0, const std::vector<Vec3>& x1, double margin) {
  Box b{x0[t[0]], x0[t[0]]};
  for (int32_t v : t) {
    b.lo = b.lo.cwiseMin(x0[v]).cwiseMin(x1[v]);
    b.hi = b.hi.cwiseMax(x0[v]).cwiseMax(x1[v]);
  }
  b.lo.array() -= margin;
  b.hi.array() += margin;
  return b;
}

bool overlap(const Box& a, const Box& b) {
  return (a.lo.array() <= b.hi.array()).all() && (b.lo.array() <= a.hi.array()).all();
}

// Items per range of the loops below.
constexpr int32_t kRange = 256;

// Calls item(i, out) for every i in [0, count), ranges of kRange items run by `run`, each appending to
// its own outputs[range]: joined in range order, the outputs are the same at any thread count.
template <typename T, typename Item>
void in_ranges(int32_t count, const RangeRunner& run, std::vector<std::vector<T>>& outputs, const Item& item) {
  const int32_t ranges = (count + kRange - 1) / kRange;
  outputs.resize(std::max<size_t>(outputs.size(), ranges));
  run(ranges, 1, [&](int32_t begin, int32_t end) {
    for (int32_t r = begin; r < end; ++r) {
      std::vector<T>& out = outputs[r];
      out.clear();
      for (int32_t i = r * kRange; i < std::min(count, (r + 1) * kRange); ++i) item(i, out);
    }
  });
  for (int32_t r = ranges; r < static_cast<int32_t>(outputs.size()); ++r) outputs[r].clear();
}

template <typename T>
void join(const std::vector<std::vector<T>>& outputs, std::vector<T>& out) {
  out.clear();
  for (const std::vector<T>& o : outputs) out.insert(out.end(), o.begin(), o.end());
}

// Up to this many triangles the broad phase tests all pairs of boxes: Embree's query costs about 0.1 ms
// however small the scene (its build and its threads' start), all pairs of 100 triangles a few µs.
constexpr size_t kAllPairsUpTo = 256;

// The pairs (s < t, ascending) that share no corner and whose `boxes` (one per triangle) overlap in double
// precision: Embree's rtcCollide, or all pairs for a few triangles.
void overlapping_pairs(const std::vector<Tri>& tris, const std::vector<Box>& boxes, SelfContactBroadPhase& b,
                       std::vector<std::array<int32_t, 2>>& out) {
  out.clear();
  if (tris.size() <= kAllPairsUpTo) {
    for (size_t s = 0; s < tris.size(); ++s)
      for (size_t t = s + 1; t < tris.size(); ++t)
        if (overlap(boxes[s], boxes[t]) && !share_a_corner(tris[s], tris[t]))
          out.push_back({static_cast<int32_t>(s), static_cast<int32_t>(t)});
    return;
  }
  b.boxes.resize(tris.size());
  for (size_t t = 0; t < tris.size(); ++t) {
    RTCBounds& r = b.boxes[t];
    r.lower_x = down(boxes[t].lo.x());
    r.lower_y = down(boxes[t].lo.y());
    r.lower_z = down(boxes[t].lo.z());
    r.upper_x = up(boxes[t].hi.x());
    r.upper_y = up(boxes[t].hi.y());
    r.upper_z = up(boxes[t].hi.z());
    r.align0 = r.align1 = 0;
  }
  for (auto& f : b.found_by_thread) f.clear();
  b.tris = &tris;
  if (b.scene && b.scene_triangles != tris.size()) {
    rtcReleaseScene(b.scene);
    b.scene = nullptr;
  }
  if (!b.scene) {
    b.scene = rtcNewScene(b.device);
    rtcSetSceneBuildQuality(b.scene, RTC_BUILD_QUALITY_LOW);
    rtcSetSceneFlags(b.scene, RTC_SCENE_FLAG_DYNAMIC);
    b.geometry = rtcNewGeometry(b.device, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(b.geometry, static_cast<unsigned int>(tris.size()));
    rtcSetGeometryUserData(b.geometry, &b);
    rtcSetGeometryBoundsFunction(b.geometry, box_bounds, nullptr);
    rtcSetGeometryBuildQuality(b.geometry, RTC_BUILD_QUALITY_REFIT);
    rtcAttachGeometry(b.scene, b.geometry);
    rtcReleaseGeometry(b.geometry);  // the scene holds it
    b.scene_triangles = tris.size();
  }
  rtcCommitGeometry(b.geometry);
  rtcCommitScene(b.scene);
  rtcCollide(b.scene, b.scene, collect_pairs, &b);
  if (const RTCError e = rtcGetDeviceError(b.device); e != RTC_ERROR_NONE)
    throw std::runtime_error("self-contact: Embree error " + std::to_string(static_cast<int>(e)));
  b.found.clear();
  for (const auto& f : b.found_by_thread) b.found.insert(b.found.end(), f.begin(), f.end());
  // Embree reports pairs in the order its threads meet them: sorted, the pairs are the same at any thread
  // count, and the exact double test drops what the float boxes' rounding added. A counting sort by the
  // first triangle, then each triangle's few partners sorted: a comparison sort of all of them took a tenth
  // of a folded sheet's frame.
  const size_t nt = tris.size();
  b.first.assign(nt + 1, 0);
  for (const auto& p : b.found) b.first[p[0] + 1] += 1;
  for (size_t t = 0; t < nt; ++t) b.first[t + 1] += b.first[t];
  b.partner.resize(b.found.size());
  b.fill.assign(b.first.begin(), b.first.end() - 1);
  for (const auto& p : b.found) b.partner[b.fill[p[0]]++] = p[1];
  for (size_t t = 0; t < nt; ++t) {
    const auto begin = b.partner.begin() + b.first[t], end = b.partner.begin() + b.first[t + 1];
    std::sort(begin, end);
    for (auto it = begin; it != end; ++it)
      if ((it == begin || *it != *(it - 1)) && overlap(boxes[t], boxes[*it]))
        out.push_back({static_cast<int32_t>(t), *it});
  }
}

// Per point, the largest per-axis distance between it in `a` or `b` and in `reference`.
void axis_distances(const std::vector<Vec3>& a, const std::vector<Vec3>& b, const std::vector<Vec3>& reference,
                    std::vector<double>& out) {
  out.resize(a.size());
  for (size_t i = 0; i < a.size(); ++i)
    out[i] = std::max((a[i] - reference[i]).cwiseAbs().maxCoeff(), (b[i] - reference[i]).cwiseAbs().maxCoeff());
}

double largest_at_corners(const Tri& t, const std::vector<double>& of_vertex) {
  return std::max({of_vertex[t[0]], of_vertex[t[1]], of_vertex[t[2]]});
}

}  // namespace

bool self_contact_candidates(const std::vector<Tri>& tris, const std::vector<Vec3>& x0, const std::vector<Vec3>& x1,
                             double margin, const RangeRunner& run, SelfContactBroadPhasePtr& broad,
                             std::vector<std::array<int32_t, 2>>& pairs) {
  pairs.clear();
  if (tris.size() < 2) return false;
  if (!broad) {
    broad.reset(new SelfContactBroadPhase);
    broad->device = rtcNewDevice(nullptr);
    if (!broad->device) throw std::runtime_error("self-contact: Embree device refused");
  }
  SelfContactBroadPhase& b = *broad;
  std::vector<Box>& boxes = b.exact;  // kept between calls: one allocation per sheet size, not per substep
  boxes.resize(tris.size());
  run(static_cast<int32_t>(tris.size()), kRange, [&](int32_t begin, int32_t end) {
    for (int32_t t = begin; t < end; ++t) boxes[t] = path_box(tris[t], x0, x1, margin);
  });
  // The cached pairs serve while every triangle's corners stay within its reach (less this call's margin)
  // of where they were found: its box then lies inside its cached one. A NaN fails the test.
  bool query = !(b.reference.size() == x0.size() && b.cached_tris == tris);
  if (!query) {
    axis_distances(x0, x1, b.reference, b.drift);
    for (size_t t = 0; t < tris.size() && !query; ++t)
      query = !(largest_at_corners(tris[t], b.drift) + margin <= b.reach[t]);
  }
  b.widest_margin = std::max(b.widest_margin, margin);
  if (query) {
    // Around x0, each triangle with room for four more steps like its corners' in this call, but no more
    // than a quarter of its size, and at least the widest margin asked for: the pairs of a sheet moving
    // steadily are found every few substeps and a still one's once; a hand's quick triangles do not widen
    // the others' boxes, and a fast sheet's boxes do not swallow their neighbours' (eight steps' room took
    // a crumpling sheet of 2 000 triangles to two million pairs a query).
    axis_distances(x1, x1, x0, b.drift);
    b.reference = x0;
    b.cached_tris = tris;
    b.reach.resize(tris.size());
    b.grown.resize(tris.size());
    const double m = b.widest_margin;
    for (size_t t = 0; t < tris.size(); ++t) {
      const double step = largest_at_corners(tris[t], b.drift);
      Box& grown = b.grown[t] = path_box(tris[t], x0, x0, 0);
      const double size = (grown.hi - grown.lo).maxCoeff();
      b.reach[t] = m + step + std::max(m, std::min(4 * step, size / 4));
      grown.lo.array() -= b.reach[t];
      grown.hi.array() += b.reach[t];
    }
    overlapping_pairs(tris, b.grown, b, b.cached);
  }
  in_ranges(static_cast<int32_t>(b.cached.size()), run, b.kept_by_range, [&](int32_t i, auto& kept) {
    const auto& p = b.cached[i];
    if (overlap(boxes[p[0]], boxes[p[1]])) kept.push_back(p);
  });
  join(b.kept_by_range, pairs);
  return query;
}

// ---- distances ---------------------------------------------------------------------------------------

namespace {

// Closest point of triangle (a, b, c) to p: its barycentric weights (Ericson, Real-Time Collision Detection §5.1.5).
Vec3 closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return Vec3(1, 0, 0);
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return Vec3(0, 1, 0);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    return Vec3(1 - v, v, 0);
  }
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return Vec3(0, 0, 1);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    return Vec3(1 - w, 0, w);
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return Vec3(0, 1 - w, w);
  }
  const double denom = va + vb + vc;
  if (!(std::abs(denom) > 0)) return Vec3(1, 0, 0);  // degenerate triangle: its first corner
  const double v = vb / denom, w = vc / denom;
  return Vec3(1 - v - w, v, w);
}

// Closest points of segments (a, b) and (c, d): parameters s on the first, t on the second (Ericson §5.1.9).
void closest_on_segments(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d, double& s, double& t) {
  const Vec3 d1 = b - a, d2 = d - c, r = a - c;
  const double aa = d1.squaredNorm(), ee = d2.squaredNorm(), f = d2.dot(r);
  const double tiny = 1e-30;
  if (aa <= tiny && ee <= tiny) {
    s = t = 0;
    return;
  }
  if (aa <= tiny) {
    s = 0;
    t = std::clamp(f / ee, 0.0, 1.0);
    return;
  }
  const double cc = d1.dot(r);
  if (ee <= tiny) {
    t = 0;
    s = std::clamp(-cc / aa, 0.0, 1.0);
    return;
  }
  const double bb = d1.dot(d2), denom = aa * ee - bb * bb;
  s = denom > 1e-14 * aa * ee ? std::clamp((bb * f - cc * ee) / denom, 0.0, 1.0) : 0.0;
  t = (bb * s + f) / ee;
  if (t < 0) {
    t = 0;
    s = std::clamp(-cc / aa, 0.0, 1.0);
  } else if (t > 1) {
    t = 1;
    s = std::clamp((bb - cc) / aa, 0.0, 1.0);
  }
}

// A pair of the mesh: a vertex and a triangle (kind 0: ids p, a, b, c) or two edges (kind 1: a, b and c, d).
// Its relative position is Σ w_i x_i with weights (1, −u, −v, −w) or (1 − s, s, −(1 − t), −t); the weights
// sum to 0, so an impulse along the relative position conserves momentum.
struct Element {
  uint8_t kind = 0;
  std::array<int32_t, 4> id{};
  bool operator<(const Element& o) const { return kind != o.kind ? kind < o.kind : id < o.id; }
  bool operator==(const Element& o) const { return kind == o.kind && id == o.id; }
};

struct Closest {
  std::array<double, 4> w{};
  Vec3 d = Vec3::Zero();  // Σ w_i x_i: from the triangle (second edge) to the vertex (first edge)
};

Closest closest(const Element& e, const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3) {
  Closest c;
  if (e.kind == 0) {
    const Vec3 b = closest_on_triangle(p0, p1, p2, p3);
    c.w = {1, -b[0], -b[1], -b[2]};
  } else {
    double s = 0, t = 0;
    closest_on_segments(p0, p1, p2, p3, s, t);
    c.w = {1 - s, s, -(1 - t), -t};
  }
  c.d = c.w[0] * p0 + c.w[1] * p1 + c.w[2] * p2 + c.w[3] * p3;
  return c;
}

// Coplanarity of the four moving points as the cubic (e1 × e2) · e3 in t, e_k = e_k0 + t (e_k1 − e_k0)
// (Bridson et al. 2002, "Collision detection"), then the candidate times: its roots in [0, 1] by bisection
// of each monotone piece, its turning points (a grazing touch has no sign change) and t = 1.
void coplanar_times(const Vec3& A0, const Vec3& A1, const Vec3& B0, const Vec3& B1, const Vec3& C0, const Vec3& C1,
                    std::vector<double>& times) {
  const Vec3 dA = A1 - A0, dB = B1 - B0, dC = C1 - C0;
  const Vec3 k0 = A0.cross(B0), k1 = A0.cross(dB) + dA.cross(B0), k2 = dA.cross(dB);
  const double d = k0.dot(C0), c = k0.dot(dC) + k1.dot(C0), b = k1.dot(dC) + k2.dot(C0), a = k2.dot(dC);
  auto f = [&](double t) { return ((a * t + b) * t + c) * t + d; };
  times.clear();
  double ends[4];
  int n = 0;
  ends[n++] = 0;
  // f' = 3a t² + 2b t + c
  const double qa = 3 * a, qb = 2 * b, qc = c;
  double crit[2];
  int nc = 0;
  if (std::abs(qa) > 0) {
    const double disc = qb * qb - 4 * qa * qc;
    if (disc >= 0) {
      const double sq = std::sqrt(disc);
      const double q = -0.5 * (qb + std::copysign(sq, qb));
      if (q != 0) {
        crit[nc++] = q / qa;
        crit[nc++] = qc / q;
      } else {
        crit[nc++] = 0;
      }
    }
  } else if (std::abs(qb) > 0) {
    crit[nc++] = -qc / qb;
  }
  std::sort(crit, crit + nc);
  for (int i = 0; i < nc; ++i)
    if (crit[i] > 0 && crit[i] < 1) {
      ends[n++] = crit[i];
      times.push_back(crit[i]);
    }
  ends[n++] = 1;
  for (int i = 0; i + 1 < n; ++i) {
    double lo = ends[i], hi = ends[i + 1];
    double flo = f(lo), fhi = f(hi);
    if (flo == 0) {
      if (lo > 0) times.push_back(lo);
      continue;
    }
    if ((flo < 0) == (fhi < 0)) continue;
    for (int it = 0; it < 60 && hi - lo > 1e-15; ++it) {
      const double mid = 0.5 * (lo + hi), fm = f(mid);
      if ((fm < 0) == (flo < 0)) {
        lo = mid;
        flo = fm;
      } else {
        hi = mid;
      }
    }
    times.push_back(hi);
  }
  // Coplanar all along (a flat sheet): no root tells when; sample the step.
  const double scale = std::max({A0.norm() + dA.norm(), B0.norm() + dB.norm(), C0.norm() + dC.norm(), 1e-300});
  if (std::max({std::abs(a), std::abs(b), std::abs(c), std::abs(d)}) <= 1e-12 * scale * scale * scale)
    for (double t : {0.25, 0.5, 0.75}) times.push_back(t);
  times.push_back(1);
  std::sort(times.begin(), times.end());
}

std::array<Vec3, 4> at(const std::array<Vec3, 4>& p0, const std::array<Vec3, 4>& p1, double t) {
  return {p0[0] + t * (p1[0] - p0[0]), p0[1] + t * (p1[1] - p0[1]), p0[2] + t * (p1[2] - p0[2]),
          p0[3] + t * (p1[3] - p0[3])};
}

// Whether the boxes of the element's two sides (the vertex and the triangle, or the two edges) over the
// points `p0` and `p1` and grown by `margin` overlap: most pairs of two overlapping triangles' boxes do not.
bool sides_overlap(const Element& e, const std::array<Vec3, 4>& p0, const std::array<Vec3, 4>& p1, double margin) {
  const int split = e.kind == 0 ? 1 : 2;
  Vec3 lo0 = p0[0].cwiseMin(p1[0]), hi0 = p0[0].cwiseMax(p1[0]);
  Vec3 lo1 = p0[3].cwiseMin(p1[3]), hi1 = p0[3].cwiseMax(p1[3]);
  for (int i = 1; i < 3; ++i) {
    Vec3& lo = i < split ? lo0 : lo1;
    Vec3& hi = i < split ? hi0 : hi1;
    lo = lo.cwiseMin(p0[i]).cwiseMin(p1[i]);
    hi = hi.cwiseMax(p0[i]).cwiseMax(p1[i]);
  }
  return (lo0.array() <= hi1.array() + margin).all() && (lo1.array() <= hi0.array() + margin).all();
}

// Whether points [0, split) and points [split, N) of `p0`, each moving straight to its place in `p1`, may
// come within `margin` of each other's hulls over the step. A point of one hull moves by a convex
// combination of its corners' displacements, so the hulls' distance shrinks by at most the largest
// displacement of a corner of one relative to a corner of the other, from at least their boxes' distance
// at the start. A sheet moving fast but nearly rigidly sweeps its neighbours' places: the swept boxes of
// sides_overlap overlap, this bound does not (fig18-crumple at 2 000 triangles: contact 21 -> 19 ms a
// frame).
template <size_t N>
bool may_come_within(const std::array<Vec3, N>& p0, const std::array<Vec3, N>& p1, size_t split, double margin) {
  Vec3 lo_a = p0[0], hi_a = p0[0], lo_b = p0[split], hi_b = p0[split];
  for (size_t i = 1; i < split; ++i) {
    lo_a = lo_a.cwiseMin(p0[i]);
    hi_a = hi_a.cwiseMax(p0[i]);
  }
  for (size_t i = split + 1; i < N; ++i) {
    lo_b = lo_b.cwiseMin(p0[i]);
    hi_b = hi_b.cwiseMax(p0[i]);
  }
  const double apart = (lo_b - hi_a).cwiseMax(lo_a - hi_b).cwiseMax(0.0).norm();
  if (apart <= margin) return true;
  double moved = 0;  // squared
  for (size_t i = 0; i < split; ++i)
    for (size_t j = split; j < N; ++j) moved = std::max(moved, ((p1[i] - p0[i]) - (p1[j] - p0[j])).squaredNorm());
  // The rounding of these few operations is far below the slack.
  return apart - std::sqrt(moved) <= margin * (1 + 1e-9) + 1e-12 * apart;
}

// The first time the element's points are within `tolerance` on their paths, or a negative number.
double first_contact(const Element& e, const std::array<Vec3, 4>& p0, const std::array<Vec3, 4>& p1, double tolerance,
                     std::vector<double>& times) {
  if (!sides_overlap(e, p0, p1, tolerance)) return -1;
  if (e.kind == 0)
    coplanar_times(p0[2] - p0[1], p1[2] - p1[1], p0[3] - p0[1], p1[3] - p1[1], p0[0] - p0[1], p1[0] - p1[1], times);
  else
    coplanar_times(p0[1] - p0[0], p1[1] - p1[0], p0[3] - p0[2], p1[3] - p1[2], p0[2] - p0[0], p1[2] - p1[0], times);
  // A pair that starts within the tolerance collides only by coming closer than it started: one resting
  // there (a zone frozen at x0) is not a collision, or it would never be resolved.
  const double start = closest(e, p0[0], p0[1], p0[2], p0[3]).d.norm();
  for (double t : times) {
    const auto q = at(p0, p1, t);
    const double d = closest(e, q[0], q[1], q[2], q[3]).d.norm();
    if (d < tolerance && d < start) return t;
  }
  return -1;
}

}  // namespace

bool vertex_triangle_ccd(const Vec3& p0, const Vec3& a0, const Vec3& b0, const Vec3& c0, const Vec3& p1,
                         const Vec3& a1, const Vec3& b1, const Vec3& c1, double tolerance, double& t) {
  std::vector<double> times;
  t = first_contact(Element{0, {0, 1, 2, 3}}, {p0, a0, b0, c0}, {p1, a1, b1, c1}, tolerance, times);
  return t >= 0;
}

bool edge_edge_ccd(const Vec3& a0, const Vec3& b0, const Vec3& c0, const Vec3& d0, const Vec3& a1, const Vec3& b1,
                   const Vec3& c1, const Vec3& d1, double tolerance, double& t) {
  std::vector<double> times;
  t = first_contact(Element{1, {0, 1, 2, 3}}, {a0, b0, c0, d0}, {a1, b1, c1, d1}, tolerance, times);
  return t >= 0;
}

// ---- the pass ----------------------------------------------------------------------------------------

namespace {

struct Pass {
  const SelfContactParams& params;
  const std::vector<Tri>& tris;
  const std::vector<Vec2>& rest;
  const std::vector<Vec3>& x0;
  const std::vector<double>& inverse_mass;
  SelfContactBroadPhasePtr& broad;
  std::vector<Vec3>& x;
  std::vector<Vec3>& v;
  SelfContactStats& stats;
  std::vector<std::array<int32_t, 2>> pairs;
  std::vector<Element> elements;
  std::vector<std::vector<Element>> elements_by_range;
  std::vector<double> times;

  // Triangles that share a corner, or a corner that is the same pattern point (a tear's twin vertices) or
  // the same point at x0 (a tip's), or that lie within the reach of a pair (two gaps) of each other in the
  // pattern: neighbours in the sheet, whose nearness is the mesh's own. The last covers the small
  // triangles a cut leaves where a tip advanced by a fraction of a millimetre: a lip's vertex there lies
  // within the gap of triangles two rings away, on its own lip or the other, with no twin between them, and
  // keeping them a gap apart in the solve stretched table-tear's lips 41% in a substep and threw the sheet
  // apart (docs/physics.md, "Self-contact").
  bool adjacent(const Tri& s, const Tri& t) const {
    for (int32_t a : s)
      for (int32_t b : t)
        if (a == b || rest[a] == rest[b] || x0[a] == x0[b]) return true;
    // Most pairs are far apart in the pattern: their boxes there, grown by two gaps, are apart.
    const double reach = 2 * params.gap;
    for (int k = 0; k < 2; ++k) {
      const double s_lo = std::min({rest[s[0]][k], rest[s[1]][k], rest[s[2]][k]});
      const double s_hi = std::max({rest[s[0]][k], rest[s[1]][k], rest[s[2]][k]});
      const double t_lo = std::min({rest[t[0]][k], rest[t[1]][k], rest[t[2]][k]});
      const double t_hi = std::max({rest[t[0]][k], rest[t[1]][k], rest[t[2]][k]});
      if (s_lo > t_hi + reach || t_lo > s_hi + reach) return false;
    }
    return near_in_pattern(s, t) || near_in_pattern(t, s);
  }
  // Whether a corner of s lies inside t in the pattern or within two gaps of one of its edges.
  bool near_in_pattern(const Tri& s, const Tri& t) const {
    for (int32_t i : s)
      if (point_triangle_distance(rest[i], rest[t[0]], rest[t[1]], rest[t[2]]) <= 2 * params.gap) return true;
    return false;
  }

  // The vertex–triangle and edge–edge pairs of the candidate triangle pairs over the current paths,
  // sorted and without repeats.
  bool moved = true;           // x changed since the last gather
  double gathered_margin = -1;  // that gather's margin
  void gather(double margin) {
    // Nothing moved since a gather with a margin at least as wide: its pairs are a superset of these (the
    // substeps where nothing touches run one broad phase).
    if (!moved && gathered_margin >= margin) return;
    moved = false;
    gathered_margin = margin;
    stats.queries += self_contact_candidates(tris, x0, x, margin, params.run, broad, pairs);
    stats.candidates += static_cast<int64_t>(pairs.size());
    in_ranges(static_cast<int32_t>(pairs.size()), params.run, elements_by_range, [&](int32_t i, auto& out) {
      const Tri& s = tris[pairs[i][0]];
      const Tri& t = tris[pairs[i][1]];
      if (adjacent(s, t)) return;
      const std::array<Vec3, 6> corners0{x0[s[0]], x0[s[1]], x0[s[2]], x0[t[0]], x0[t[1]], x0[t[2]]};
      const std::array<Vec3, 6> corners1{x[s[0]], x[s[1]], x[s[2]], x[t[0]], x[t[1]], x[t[2]]};
      if (!may_come_within(corners0, corners1, 3, margin)) return;
      // Only the pairs whose own boxes overlap: most of two triangles' 15 do not, and the sort is the cost.
      auto add = [&](const Element& e) {
        const auto p0 = start(e), p1 = end(e);
        if (sides_overlap(e, p0, p1, margin) && may_come_within(p0, p1, e.kind == 0 ? 1 : 2, margin))
          out.push_back(e);
      };
      for (int i = 0; i < 3; ++i) {
        add(Element{0, {s[i], t[0], t[1], t[2]}});
        add(Element{0, {t[i], s[0], s[1], s[2]}});
        for (int j = 0; j < 3; ++j) {
          std::array<int32_t, 2> e{s[i], s[(i + 1) % 3]}, f{t[j], t[(j + 1) % 3]};
          if (e[0] > e[1]) std::swap(e[0], e[1]);
          if (f[0] > f[1]) std::swap(f[0], f[1]);
          if (f < e) std::swap(e, f);
          add(Element{1, {e[0], e[1], f[0], f[1]}});
        }
      }
    });
    join(elements_by_range, elements);
    std::sort(elements.begin(), elements.end());
    elements.erase(std::unique(elements.begin(), elements.end()), elements.end());
  }

  std::array<Vec3, 4> start(const Element& e) const { return {x0[e.id[0]], x0[e.id[1]], x0[e.id[2]], x0[e.id[3]]}; }
  std::array<Vec3, 4> end(const Element& e) const { return {x[e.id[0]], x[e.id[1]], x[e.id[2]], x[e.id[3]]}; }

  // Changes the element's relative velocity along n by dvn (> 0 opens it) and its tangential velocity
  // `vt` by Coulomb's μ dvn at most (Bridson et al. 2002, "Friction"); the impulse on each point is its
  // weight times its inverse mass, so the momentum is unchanged.
  bool impulse(const Element& e, const std::array<double, 4>& w, const Vec3& n, double dvn, const Vec3& vt) {
    double denom = 0, free = 0;
    for (int i = 0; i < 4; ++i) {
      denom += w[i] * w[i] * inverse_mass[e.id[i]];
      if (inverse_mass[e.id[i]] > 0) free += w[i] * w[i];
    }
    // All held, or the free points' weights so small that the impulse would fling them (a held edge that
    // touches a free one at its held end): left to the collision passes and impact zones.
    if (!(denom > 0) || free < 0.01) return false;
    Vec3 dv = (dvn / denom) * n;
    const double vt_norm = vt.norm();
    if (params.friction > 0 && vt_norm > 0) dv -= (std::min(params.friction * dvn, vt_norm) / denom / vt_norm) * vt;
    const double h = params.dt;
    moved = true;
    for (int i = 0; i < 4; ++i) {
      const Vec3 d = (w[i] * inverse_mass[e.id[i]]) * dv;
      v[e.id[i]] += d;
      x[e.id[i]] += h * d;
    }
    return true;
  }

  Vec3 step_velocity(const Element& e, const std::array<double, 4>& w) const {
    Vec3 r = Vec3::Zero();
    for (int i = 0; i < 4; ++i) r += w[i] * (x[e.id[i]] - x0[e.id[i]]);
    return r / params.dt;
  }

  // Bridson et al. 2002, "Repulsions": a pair closer than the gap at x0 that approaches, or opens by less
  // than a tenth of its overlap per step, is given that opening velocity (an inelastic impulse plus the
  // repulsion), with friction. Gauss–Seidel in the elements' order.
  void repulsions() {
    const double gap = params.gap, h = params.dt;
    gather(gap);
    for (const Element& e : elements) {
      const auto p = start(e);
      if (!sides_overlap(e, p, p, gap)) continue;
      const Closest c = closest(e, p[0], p[1], p[2], p[3]);
      const double dist = c.d.norm();
      if (dist >= gap) continue;
      stats.proximities += 1;
      Vec3 n;
      if (dist > 1e-6 * gap) {
        n = c.d / dist;
      } else {  // touching: the face's (edges') normal, on the side the pair moves apart to
        n = e.kind == 0 ? (p[2] - p[1]).cross(p[3] - p[1]) : (p[1] - p[0]).cross(p[3] - p[2]);
        if (n.norm() == 0) continue;
        n.normalize();
        if (n.dot(step_velocity(e, c.w)) < 0) n = -n;
      }
      const Vec3 vr = step_velocity(e, c.w);
      const double vn = n.dot(vr);
      const double dvn = 0.1 * (gap - dist) / h - vn;
      if (dvn <= 0) continue;
      if (impulse(e, c.w, n, dvn, vr - vn * n)) stats.repulsions += 1;
    }
  }

  // The elements colliding on their current paths, or with `apply` each stopped as it is met (Bridson et
  // al. 2002, "Collision detection" and the impulses of "Collision response"): the collision's normal at
  // its time, oriented by the side the pair starts on, and an impulse that ends the step with the pair
  // 0.1 gap apart along it.
  int64_t collisions(bool apply, std::vector<Element>* hits) {
    const double tol = params.ccd_tolerance > 0 ? params.ccd_tolerance : 0.01 * params.gap;
    gather(tol);
    int64_t count = 0;
    for (const Element& e : elements) {
      const auto p0 = start(e);
      const auto p1 = end(e);
      const double t = first_contact(e, p0, p1, tol, times);
      if (t < 0) continue;
      count += 1;
      if (hits) hits->push_back(e);
      if (!apply) continue;
      const auto q = at(p0, p1, t);
      const Closest c = closest(e, q[0], q[1], q[2], q[3]);
      Vec3 d0 = Vec3::Zero(), d1 = Vec3::Zero();
      for (int i = 0; i < 4; ++i) {
        d0 += c.w[i] * p0[i];
        d1 += c.w[i] * p1[i];
      }
      // The face's normal, or the edges' common normal; for edges within ~6° of parallel, whose cross
      // product points anywhere about them, against the pair's approach across the edge.
      Vec3 n;
      if (e.kind == 0) {
        n = (q[2] - q[1]).cross(q[3] - q[1]);
      } else {
        const Vec3 a = q[1] - q[0], b = q[3] - q[2];
        n = a.cross(b);
        if (n.norm() < 0.1 * a.norm() * b.norm() && a.norm() > 0) {
          const Vec3 along = a.normalized();
          n = d0 - d1;
          n -= along.dot(n) * along;
        }
      }
      if (n.norm() == 0) n = d0;
      if (n.norm() == 0) continue;
      n.normalize();
      if (n.dot(d0) < 0) n = -n;
      const double dvn = (0.1 * params.gap - n.dot(d1)) / params.dt;
      if (dvn <= 0) continue;
      const Vec3 vr = (d1 - d0) / params.dt;
      impulse(e, c.w, n, dvn, vr - n.dot(vr) * n);
    }
    return count;
  }

  // Bridson et al. 2002, "Rigid impact zones" (Provot 1997): the vertices of the colliding pairs, merged
  // with the zones of earlier rounds, move as one rigid body over the step — the zone's momentum and
  // angular momentum about its centre of mass at x0 kept — or, with `translate`, with its momentum only
  // (its pairs then stay as they were at x0, which had none colliding). A zone with a held vertex follows
  // the held vertices' mean step.
  void make_zones(const std::vector<Element>& hits, std::vector<int32_t>& parent, bool translate) {
    auto find = [&](int32_t a) {
      while (parent[a] != a) a = parent[a] = parent[parent[a]];
      return a;
    };
    for (const Element& e : hits)
      for (int i = 1; i < 4; ++i) {
        const int32_t a = find(e.id[0]), b = find(e.id[i]);
        if (a != b) parent[std::max(a, b)] = std::min(a, b);
      }
    // Zones in the order of their smallest vertex (each set's root), their vertices ascending.
    const auto n = static_cast<int32_t>(parent.size());
    std::vector<int32_t> root(n), size(n, 0), zone_of(n, -1);
    for (int32_t a = 0; a < n; ++a) size[root[a] = find(a)] += 1;
    std::vector<std::vector<int32_t>> zones;
    for (int32_t a = 0; a < n; ++a) {
      if (size[root[a]] < 2) continue;
      if (zone_of[root[a]] < 0) {
        zone_of[root[a]] = static_cast<int32_t>(zones.size());
        zones.emplace_back();
      }
      zones[zone_of[root[a]]].push_back(a);
    }
    const double h = params.dt;
    moved = true;
    for (const std::vector<int32_t>& zone : zones) {
      stats.zones += 1;
      double mass = 0;
      Vec3 cm = Vec3::Zero(), p = Vec3::Zero(), held_step = Vec3::Zero();
      int held = 0;
      for (int32_t a : zone) {
        if (inverse_mass[a] == 0) {
          held_step += x[a] - x0[a];
          held += 1;
          continue;
        }
        const double m = 1 / inverse_mass[a];
        mass += m;
        cm += m * x0[a];
        p += m * (x[a] - x0[a]);
      }
      if (mass == 0) continue;
      cm /= mass;
      const Vec3 step = held > 0 ? Vec3(held_step / held) : Vec3(p / mass);
      Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
      if (!translate && held == 0) {
        Vec3 l = Vec3::Zero();
        Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();
        for (int32_t a : zone) {
          const double m = 1 / inverse_mass[a];
          const Vec3 r = x0[a] - cm;
          l += m * r.cross(x[a] - x0[a] - step);
          inertia += m * (r.squaredNorm() * Eigen::Matrix3d::Identity() - r * r.transpose());
        }
        // A zone of collinear points has no inertia about their line: the pseudo-inverse spins it about
        // the others only.
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(inertia);
        Vec3 inv = Vec3::Zero();
        for (int k = 0; k < 3; ++k)
          if (eig.eigenvalues()[k] > 1e-12 * eig.eigenvalues().maxCoeff()) inv[k] = 1 / eig.eigenvalues()[k];
        const Vec3 omega_h = eig.eigenvectors() * inv.asDiagonal() * eig.eigenvectors().transpose() * l;
        if (omega_h.norm() > 0) rotation = Eigen::AngleAxisd(omega_h.norm(), omega_h.normalized()).toRotationMatrix();
      }
      for (int32_t a : zone) {
        if (inverse_mass[a] == 0) continue;
        const Vec3 target = cm + step + rotation * (x0[a] - cm);
        v[a] += (target - x[a]) / h;
        x[a] = target;
      }
    }
  }
};

}  // namespace

SelfContactStats self_contact_proximities(const SelfContactParams& params, const std::vector<Tri>& tris,
                                          const std::vector<Vec2>& rest, const std::vector<Vec3>& x0,
                                          const std::vector<Vec3>& x1, SelfContactBroadPhasePtr& broad,
                                          std::vector<ProximityPair>& out) {
  out.clear();
  SelfContactStats stats;
  const auto t0 = std::chrono::steady_clock::now();
  // The pass's gather reads the end positions only: no masses, no velocities.
  std::vector<Vec3> x = x1, no_velocity;
  const std::vector<double> no_mass;
  Pass pass{params, tris, rest, x0, no_mass, broad, x, no_velocity, stats, {}, {}, {}, {}};
  pass.gather(2 * params.gap);
  for (const Element& e : pass.elements) {
    if (e.kind != 0) continue;
    const auto p = pass.start(e);
    const Closest c = closest(e, p[0], p[1], p[2], p[3]);
    double dist = c.d.norm();
    if (!(dist > 1e-6 * params.gap)) continue;
    Vec3 moved = Vec3::Zero();
    for (int i = 0; i < 4; ++i) moved += c.w[i] * (x1[e.id[i]] - x0[e.id[i]]);
    if (dist >= 2 * params.gap + moved.norm()) continue;
    // A vertex over the triangle, or beside its border by less than the gap, is kept off its plane: a
    // folded layer's border lies right over the other layer's, and a normal from the nearest point on the
    // border, tilted, let the vertex slide off it and down beside it.
    Vec3 n = c.d / dist;
    const Vec3 face = (p[2] - p[1]).cross(p[3] - p[1]);
    if (face.norm() > 0) {
      const Vec3 f = face.normalized();
      const double across = f.dot(c.d);
      if ((c.d - across * f).norm() < params.gap && std::abs(across) > 1e-6 * params.gap) {
        n = across > 0 ? f : Vec3(-f);
        dist = std::abs(across);
      }
    }
    out.push_back({e.id[0], {e.id[1], e.id[2], e.id[3]}, {-c.w[1], -c.w[2], -c.w[3]}, n, dist});
  }
  // The elements are sorted by (vertex, triangle corners): so is `out`.
  stats.proximities = static_cast<int64_t>(out.size());
  stats.ms = ms_since(t0);
  return stats;
}

SelfContactStats resolve_self_contact(const SelfContactParams& params, const std::vector<Tri>& tris,
                                      const std::vector<Vec2>& rest, const std::vector<Vec3>& x0,
                                      const std::vector<double>& inverse_mass, SelfContactBroadPhasePtr& broad,
                                      std::vector<Vec3>& x, std::vector<Vec3>& v) {
  SelfContactStats stats;
  const auto t0 = std::chrono::steady_clock::now();
  Pass pass{params, tris, rest, x0, inverse_mass, broad, x, v, stats, {}, {}, {}, {}};
  [&] {
    if (params.repulsions) pass.repulsions();
    for (int32_t k = 0; k < params.ccd_passes; ++k) {
      const int64_t hits = pass.collisions(true, nullptr);
      stats.collisions += hits;
      if (hits == 0) return;
    }
    std::vector<int32_t> parent(x.size());
    std::iota(parent.begin(), parent.end(), 0);
    std::vector<Element> hits;
    for (int32_t k = 0; k < params.zone_passes; ++k) {
      hits.clear();
      if (pass.collisions(false, &hits) == 0) return;
      pass.make_zones(hits, parent, k >= params.zone_passes / 2);
    }
    hits.clear();
    stats.unresolved = pass.collisions(false, &hits);
  }();
  stats.ms = ms_since(t0);
  return stats;
}

}  // namespace pt
