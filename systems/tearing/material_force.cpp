// Crack driving force by the domain J-integral (see material_force.hpp).
#include "systems/tearing/material_force.hpp"

#include <algorithm>
#include <cmath>

namespace pt {

double domain_radius(const std::vector<Vec2>& rest, int32_t p, const std::vector<int32_t>& others, double radius) {
  if (p < 0 || p >= static_cast<int32_t>(rest.size())) return 0;
  for (int32_t o : others)
    if (o >= 0 && o != p && o < static_cast<int32_t>(rest.size()))
      radius = std::min(radius, (rest[o] - rest[p]).norm());
  return radius;
}

DrivingForce crack_driving_force(const Vertices& verts, const Triangles& tris, const Topology& topo, int32_t p,
                                 double radius, const MembraneParams& params, DrivingForceScratch& scratch) {
  DrivingForce out;
  const int32_t nv = verts.size();
  if (p < 0 || p >= nv || !(radius > 0) || topo.vertex_count() != nv) return out;
  out.radius = radius;
  const std::vector<Vec2>& rest = verts.rest;
  const Vec2 center = rest[p];
  // q = 1 at p, 1 − |X − X_p| / radius elsewhere (0 beyond).
  auto weight = [&](int32_t v) { return v == p ? 1.0 : std::max(0.0, 1.0 - (rest[v] - center).norm() / radius); };

  // The domain: vertices reached from p through vertices with q > 0 (breadth first over the fans), and
  // every triangle of their fans (a triangle with a corner of q > 0 may have a non-zero ∇q). Each visited
  // vertex keeps its q; a corner not visited has q = 0.
  if (scratch.stamp.size() < static_cast<size_t>(nv)) {
    scratch.stamp.resize(nv, 0);
    scratch.weight.resize(nv, 0.0);
  }
  if (++scratch.call == 0) {  // wrapped: clear the stamps once
    std::fill(scratch.stamp.begin(), scratch.stamp.end(), 0);
    scratch.call = 1;
  }
  const int32_t call = scratch.call;
  std::vector<int32_t>& queue = scratch.queue;
  std::vector<int32_t>& domain = scratch.triangles;
  queue.assign(1, p);
  domain.clear();
  scratch.stamp[p] = call;
  scratch.weight[p] = 1.0;
  for (size_t head = 0; head < queue.size(); ++head) {
    const int32_t v = queue[head];
    for (const int32_t t : topo.fan(v)) {
      domain.push_back(t);
      for (int32_t c : tris.tri[t]) {
        if (scratch.stamp[c] == call) continue;
        const double q = weight(c);
        if (!(q > 0)) continue;
        scratch.stamp[c] = call;
        scratch.weight[c] = q;
        queue.push_back(c);
      }
    }
  }
  auto q_of = [&](int32_t v) { return scratch.stamp[v] == call ? scratch.weight[v] : 0.0; };
  std::sort(domain.begin(), domain.end());
  domain.erase(std::unique(domain.begin(), domain.end()), domain.end());

  // J = −Σ_t A_t (W I − Fᵀ P) ∇q_t, per unit thickness.
  Vec2 sum = Vec2::Zero();
  for (int32_t t : domain) {
    const Tri& c = tris.tri[t];
    const Mat2& rest_inv = tris.rest_inv[t];
    // F = Σ_a x_a ∇N_aᵀ with ∇N_1, ∇N_2 the rows of rest_inv and ∇N_0 = −∇N_1 − ∇N_2.
    const Vec2 g1 = rest_inv.row(0).transpose(), g2 = rest_inv.row(1).transpose();
    const Vec2 grad_q = q_of(c[0]) * (-g1 - g2) + q_of(c[1]) * g1 + q_of(c[2]) * g2;
    if (grad_q.squaredNorm() == 0) continue;
    CorotatedFrame frame;
    corotated_frame(verts.x[c[0]], verts.x[c[1]], verts.x[c[2]], rest_inv, frame);
    const double dilation = frame.trace_s - 2;
    const double pinch = pinched_fraction(tris.pinched, t);  // a finger's triangle (Triangles::pinched)
    const MembraneParams own = pinch > 0 ? pinched_params(params, pinch) : params;
    const double energy = corotated_energy_density(frame.F, frame.R, dilation, own);
    const Eigen::Matrix<double, 3, 2> stress = corotated_stress(frame.F, frame.R, dilation, own);
    const Mat2 eshelby = energy * Mat2::Identity() - frame.F.transpose() * stress;
    sum += tris.rest_area[t] * (eshelby * grad_q);
    ++out.triangles;
  }
  out.j = -sum;
  if (!out.j.allFinite()) out.j = Vec2::Zero();
  return out;
}

}  // namespace pt
