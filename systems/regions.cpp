#include "systems/regions.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>

namespace pt {

namespace {
Vec3 unit_normal(const std::vector<Vec3>& x, const Tri& t) {
  const Vec3 n = (x[t[1]] - x[t[0]]).cross(x[t[2]] - x[t[0]]);
  const double len = n.norm();
  return len > 0 ? Vec3(n / len) : Vec3::Zero();
}
}  // namespace

void triangle_bending(const std::vector<Vec3>& x, const std::vector<Tri>& tri, const Topology& topo,
                      std::vector<double>& bending) {
  const int32_t nt = static_cast<int32_t>(tri.size());
  bending.assign(nt, 0.0);
  for (int32_t t = 0; t < nt; ++t) {
    const Vec3 n0 = unit_normal(x, tri[t]);
    const double area = 0.5 * (x[tri[t][1]] - x[tri[t][0]]).cross(x[tri[t][2]] - x[tri[t][0]]).norm();
    if (area <= 0) continue;
    double sum = 0;
    for (int32_t i = 0; i < 3; ++i) {
      const int32_t o = topo.neighbor[t][i];
      if (o < 0) continue;
      const Vec3 a = x[tri[t][i]], b = x[tri[t][(i + 1) % 3]];
      const Vec3 n1 = unit_normal(x, tri[o]);
      const Vec3 e = b - a;
      const double len = e.norm();
      if (len <= 0) continue;
      // Signed dihedral angle about the shared edge: positive when the neighbour folds towards n0.
      const double angle = std::atan2(n0.cross(n1).dot(e / len), n0.dot(n1));
      sum += angle * len;
    }
    // ∫H dA ≈ ½ Σ θ_e |e| over a region; each edge is shared by two triangles, so triangle t holds
    // ¼ Σ θ_e |e|, and its normal curvature 2H ≈ ½ Σ θ_e |e| / A_t (a cylinder of radius r gives 1/r).
    bending[t] = -0.5 * sum / area;
  }
}

RegionSummary classify_regions(const std::vector<Vec3>& x, const std::vector<Tri>& tri, const Topology& topo,
                               const RegionParams& params, std::vector<int32_t>& tri_region,
                               std::vector<Region>& regions, std::vector<uint8_t>& flags) {
  const int32_t nt = static_cast<int32_t>(tri.size());
  const int32_t nv = static_cast<int32_t>(flags.size());
  std::vector<double> bending;
  triangle_bending(x, tri, topo, bending);
  std::vector<RegionKind> kind(nt, RegionKind::Flat);
  for (int32_t t = 0; t < nt; ++t) {
    if (bending[t] > params.flat_curvature) kind[t] = RegionKind::CurvedPositive;
    else if (bending[t] < -params.flat_curvature) kind[t] = RegionKind::CurvedNegative;
  }
  // Connected components of equal kind, seeded in ascending triangle order (deterministic ids).
  tri_region.assign(nt, -1);
  regions.clear();
  std::vector<int32_t> stack;
  for (int32_t s = 0; s < nt; ++s) {
    if (tri_region[s] >= 0) continue;
    const int32_t id = static_cast<int32_t>(regions.size());
    regions.push_back(Region{kind[s], 0, -1});
    tri_region[s] = id;
    stack.push_back(s);
    while (!stack.empty()) {
      const int32_t t = stack.back();
      stack.pop_back();
      ++regions[id].triangle_count;
      for (int32_t o : topo.neighbor[t])
        if (o >= 0 && tri_region[o] < 0 && kind[o] == kind[s]) {
          tri_region[o] = id;
          stack.push_back(o);
        }
    }
  }
  RegionSummary summary;
  summary.regions = static_cast<int32_t>(regions.size());
  for (int32_t v = 0; v < nv; ++v) {
    flags[v] &= static_cast<uint8_t>(~(kJunction | kSingular));
    const int32_t b = topo.vt_offset[v], e = topo.vt_offset[v + 1];
    if (b == e) continue;
    if (topo.boundary_next[v] >= 0) {
      // Junction: the boundary vertex's fan touches regions of different kind (flat/curved or signs).
      const RegionKind k0 = regions[tri_region[topo.vt_tri[b]]].kind;
      bool mixed = false;
      for (int32_t k = b + 1; k < e && !mixed; ++k) mixed = regions[tri_region[topo.vt_tri[k]]].kind != k0;
      if (mixed) {
        flags[v] |= kJunction;
        ++summary.junctions;
      }
    } else {
      // Interior singular point: bending concentrated at this vertex (a cone apex).
      double peak = 0;
      for (int32_t k = b; k < e; ++k) peak = std::max(peak, std::abs(bending[topo.vt_tri[k]]));
      if (peak > params.singular_curvature) {
        flags[v] |= kSingular;
        ++summary.singular;
        const int32_t r = tri_region[topo.vt_tri[b]];
        if (regions[r].apex < 0) regions[r].apex = v;
      }
    }
  }
  return summary;
}

}  // namespace pt
