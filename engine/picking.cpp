#include "engine/picking.hpp"

#include <Eigen/Geometry>
#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

namespace pt {

namespace {

void embree_error(void*, RTCError code, const char* message) {
  std::fprintf(stderr, "papertear: embree error %d: %s\n", static_cast<int>(code), message ? message : "");
}

// Ray / triangle in double (Möller–Trumbore, both sides): refines Embree's float hit.
bool intersect_double(const Vec3& o, const Vec3& d, const Vec3& a, const Vec3& b, const Vec3& c, double& t,
                      double& u, double& v) {
  const Vec3 e1 = b - a, e2 = c - a;
  const Vec3 p = d.cross(e2);
  const double det = e1.dot(p);
  if (det == 0.0 || !std::isfinite(det)) return false;
  const double inv = 1.0 / det;
  const Vec3 s = o - a;
  u = s.dot(p) * inv;
  const Vec3 q = s.cross(e1);
  v = d.dot(q) * inv;
  t = e2.dot(q) * inv;
  return std::isfinite(t) && std::isfinite(u) && std::isfinite(v);
}

}  // namespace

struct Picker::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  RTCGeometry geometry = nullptr;
  float* vertex_buffer = nullptr;  // owned by the geometry
  uint64_t topology_version = ~uint64_t{0};
  int32_t nv = -1, nt = -1;
  std::vector<Vec3> x;
  std::vector<Vec2> rest;
  std::vector<Tri> tri;
  int64_t rebuilds = 0, refits = 0;

  Impl() {
    device = rtcNewDevice("threads=1");  // picking is a single ray: no worker pool needed
    if (!device) throw std::runtime_error("embree: rtcNewDevice failed");
    rtcSetDeviceErrorFunction(device, embree_error, nullptr);
  }
  ~Impl() {
    release_scene();
    if (device) rtcReleaseDevice(device);
  }

  void release_scene() {
    if (scene) rtcReleaseScene(scene);
    scene = nullptr;
    geometry = nullptr;
    vertex_buffer = nullptr;
  }

  void copy_vertices() {
    for (int32_t i = 0; i < nv; ++i) {
      vertex_buffer[3 * i + 0] = static_cast<float>(x[i].x());
      vertex_buffer[3 * i + 1] = static_cast<float>(x[i].y());
      vertex_buffer[3 * i + 2] = static_cast<float>(x[i].z());
    }
  }

  void rebuild() {
    release_scene();
    scene = rtcNewScene(device);
    rtcSetSceneFlags(scene, RTC_SCENE_FLAG_DYNAMIC | RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_LOW);
    if (nt > 0 && nv > 0) {
      RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
      rtcSetGeometryBuildQuality(g, RTC_BUILD_QUALITY_REFIT);
      vertex_buffer = static_cast<float*>(
          rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), nv));
      auto* index = static_cast<unsigned*>(
          rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), nt));
      if (!vertex_buffer || !index) throw std::runtime_error("embree: buffer allocation failed");
      copy_vertices();
      for (int32_t t = 0; t < nt; ++t)
        for (int k = 0; k < 3; ++k) index[3 * t + k] = static_cast<unsigned>(tri[t][k]);
      rtcCommitGeometry(g);
      rtcAttachGeometryByID(scene, g, 0);
      rtcReleaseGeometry(g);  // the scene holds it
      geometry = g;
    }
    rtcCommitScene(scene);
    ++rebuilds;
  }

  void update(const Sheet& s) {
    const int32_t new_nv = s.verts.size(), new_nt = s.tris.size();
    x = s.verts.x;
    const bool topology = !scene || s.topology_version != topology_version || new_nv != nv || new_nt != nt;
    if (topology) {
      nv = new_nv;
      nt = new_nt;
      rest = s.verts.rest;
      tri = s.tris.tri;
      topology_version = s.topology_version;
      rebuild();
      return;
    }
    // Pattern positions only change with the topology, but keep them exact anyway.
    rest = s.verts.rest;
    if (geometry) {
      copy_vertices();
      rtcUpdateGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0);
      rtcCommitGeometry(geometry);
    }
    rtcCommitScene(scene);
    ++refits;
  }

  std::optional<PickHit> pick(const Vec3& o, const Vec3& d, double tnear, double tfar) const {
    if (!geometry || !(d.squaredNorm() > 0) || !o.allFinite() || !d.allFinite()) return std::nullopt;
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRayHit rh{};
    rh.ray.org_x = static_cast<float>(o.x());
    rh.ray.org_y = static_cast<float>(o.y());
    rh.ray.org_z = static_cast<float>(o.z());
    rh.ray.dir_x = static_cast<float>(d.x());
    rh.ray.dir_y = static_cast<float>(d.y());
    rh.ray.dir_z = static_cast<float>(d.z());
    rh.ray.tnear = static_cast<float>(std::max(0.0, tnear));
    rh.ray.tfar = std::isfinite(tfar) ? static_cast<float>(tfar) : std::numeric_limits<float>::infinity();
    rh.ray.mask = ~0u;
    rh.ray.flags = 0;
    rh.ray.time = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene, &context, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;

    PickHit h;
    h.triangle = static_cast<int32_t>(rh.hit.primID);
    const Tri& c = tri[h.triangle];
    const Vec3 &a = x[c[0]], &b = x[c[1]], &e = x[c[2]];
    double t = rh.ray.tfar, u = rh.hit.u, v = rh.hit.v;
    double td, ud, vd;
    // Refine in double; keep Embree's answer if the refinement is degenerate or leaves the triangle by
    // more than float round-off.
    if (intersect_double(o, d, a, b, e, td, ud, vd) && ud >= -1e-5 && vd >= -1e-5 && ud + vd <= 1 + 1e-5) {
      t = td;
      u = std::clamp(ud, 0.0, 1.0);
      v = std::clamp(vd, 0.0, 1.0 - u);
    }
    h.t = t;
    h.u = u;
    h.v = v;
    const double w = 1.0 - u - v;
    h.point = w * a + u * b + v * e;
    h.uv = w * rest[c[0]] + u * rest[c[1]] + v * rest[c[2]];
    const Vec3 n = (b - a).cross(e - a);
    h.normal = n.norm() > 0 ? Vec3(n.normalized()) : Vec3(0, 0, 1);
    return h;
  }
};

Picker::Picker() : impl_(std::make_unique<Impl>()) {}
Picker::~Picker() = default;
void Picker::update(const Sheet& sheet) { impl_->update(sheet); }
std::optional<PickHit> Picker::pick(const Vec3& origin, const Vec3& direction, double tnear, double tfar) const {
  return impl_->pick(origin, direction, tnear, tfar);
}
int64_t Picker::rebuilds() const { return impl_->rebuilds; }
int64_t Picker::refits() const { return impl_->refits; }

}  // namespace pt
