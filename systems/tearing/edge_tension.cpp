#include "systems/tearing/edge_tension.hpp"

#include <algorithm>

namespace pt {

Mat2 triangle_membrane_stress(const std::vector<Vec3>& x, const Tri& tri, const Mat2& rest_inv,
                              const MembraneParams& membrane) {
  const Eigen::Matrix<double, 3, 2> F = deformation_gradient(x, tri, rest_inv);
  const Mat2 strain = corotated_strain(F, polar_rotation(F));
  Mat2 tau = 2 * membrane.mu * strain + membrane.lambda * strain.trace() * Mat2::Identity();
  strain_limit_term(strain, membrane, tau);
  return membrane.thickness * tau;
}

EdgeTension edge_tension(const Vertices& verts, const Triangles& tris, const Topology& topo, int32_t p,
                         double radius, const MembraneParams& membrane, EdgeTensionScratch& scratch) {
  EdgeTension out;
  if (p < 0 || p >= topo.vertex_count() || topo.boundary_next[p] < 0 || topo.boundary_prev[p] < 0) return out;
  const Vec2 along = verts.rest[topo.boundary_next[p]] - verts.rest[topo.boundary_prev[p]];
  if (!(along.norm() > 0)) return out;
  out.tangent = along.normalized();
  // Triangles with a corner within `radius` of p, reached through the fans from p (so the far side of a
  // tear across open space is not read): a breadth-first walk over vertices.
  const int32_t nv = verts.size();
  if (static_cast<int32_t>(scratch.stamp.size()) < nv) scratch.stamp.assign(nv, -1);
  const int32_t call = ++scratch.call;
  scratch.queue.assign(1, p);
  scratch.stamp[p] = call;
  scratch.triangles.clear();
  for (size_t k = 0; k < scratch.queue.size(); ++k) {
    const int32_t v = scratch.queue[k];
    for (const int32_t t : topo.fan(v)) {
      scratch.triangles.push_back(t);
      for (const int32_t w : tris.tri[t]) {
        if (scratch.stamp[w] == call) continue;
        scratch.stamp[w] = call;
        if ((verts.rest[w] - verts.rest[p]).norm() < radius) scratch.queue.push_back(w);
      }
    }
  }
  std::sort(scratch.triangles.begin(), scratch.triangles.end());  // each once, summed in id order
  scratch.triangles.erase(std::unique(scratch.triangles.begin(), scratch.triangles.end()), scratch.triangles.end());
  Mat2 sum = Mat2::Zero();
  double area = 0;
  for (const int32_t t : scratch.triangles) {
    const double pinch = pinched_fraction(tris.pinched, t);
    sum += tris.rest_area[t] * triangle_membrane_stress(verts.x, tris.tri[t], tris.rest_inv[t],
                                                        pinch > 0 ? pinched_params(membrane, pinch) : membrane);
    area += tris.rest_area[t];
  }
  out.triangles = static_cast<int32_t>(scratch.triangles.size());
  if (area > 0) out.tension = out.tangent.dot((sum / area) * out.tangent);
  return out;
}

}  // namespace pt
