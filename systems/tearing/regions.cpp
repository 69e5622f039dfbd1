#include "systems/tearing/regions.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>

namespace pt {

void triangle_bending(const std::vector<Vec3>& x, const std::vector<Tri>& tri, const Topology& topo,
                      std::vector<double>& bending) {
  const int32_t nt = static_cast<int32_t>(tri.size());
  // Normals and areas once per triangle, each shared edge's dihedral angle once (atan2 dominates).
  thread_local std::vector<Vec3> normal;
  thread_local std::vector<double> area;
  normal.resize(nt);
  area.resize(nt);
  for (int32_t t = 0; t < nt; ++t) {
    const Vec3 n = (x[tri[t][1]] - x[tri[t][0]]).cross(x[tri[t][2]] - x[tri[t][0]]);
    const double len = n.norm();
    normal[t] = len > 0 ? Vec3(n / len) : Vec3::Zero();
    area[t] = 0.5 * len;
  }
  bending.assign(nt, 0.0);
  for (int32_t t = 0; t < nt; ++t)
    for (int32_t i = 0; i < 3; ++i) {
      const int32_t o = topo.neighbor[t][i];
      if (o <= t) continue;  // boundary, or done from the other side
      const Vec3 e = x[tri[t][(i + 1) % 3]] - x[tri[t][i]];
      const double len = e.norm();
      if (len <= 0) continue;
      // Signed dihedral angle about the shared edge; the same seen from either triangle (the edge and
      // the normals both swap).
      const double angle = std::atan2(normal[t].cross(normal[o]).dot(e / len), normal[t].dot(normal[o]));
      bending[t] += angle * len;
      bending[o] += angle * len;
    }
  // ∫H dA ≈ ½ Σ θ_e |e| over a region; each edge is shared by two triangles, so triangle t holds
  // ¼ Σ θ_e |e|, and its normal curvature 2H ≈ ½ Σ θ_e |e| / A_t (a cylinder of radius r gives 1/r).
  for (int32_t t = 0; t < nt; ++t) bending[t] = area[t] > 0 ? -0.5 * bending[t] / area[t] : 0.0;
}

RegionSummary classify_regions(const std::vector<Vec3>& x, const std::vector<Tri>& tri, const Topology& topo,
                               const RegionParams& params, std::vector<int32_t>& tri_region,
                               std::vector<Region>& regions, std::vector<uint8_t>& flags) {
  const int32_t nt = static_cast<int32_t>(tri.size());
  const int32_t nv = static_cast<int32_t>(flags.size());
  thread_local std::vector<double> raw;
  triangle_bending(x, tri, topo, raw);
  // A coarse sheet wrinkles at the scale of its triangles (paper is floppy), so one triangle's bending
  // flips sign from neighbour to neighbour. Regions are about the shape at the scale of the hands:
  // average each triangle with its edge neighbours (area-weighted) smoothing_passes times.
  std::vector<double>& bending = raw;
  std::vector<double> next, area;
  if (params.smoothing_passes > 0) {
    next.resize(nt);
    area.resize(nt);
    for (int32_t t = 0; t < nt; ++t)
      area[t] = 0.5 * (x[tri[t][1]] - x[tri[t][0]]).cross(x[tri[t][2]] - x[tri[t][0]]).norm();
  }
  for (int32_t pass = 0; pass < params.smoothing_passes; ++pass) {
    for (int32_t t = 0; t < nt; ++t) {
      double sum = area[t] * bending[t], w = area[t];
      for (int32_t o : topo.neighbor[t])
        if (o >= 0) sum += area[o] * bending[o], w += area[o];
      next[t] = w > 0 ? sum / w : bending[t];
    }
    bending.swap(next);
  }
  std::vector<RegionKind> kind(nt, RegionKind::Flat);
  for (int32_t t = 0; t < nt; ++t) {
    if (bending[t] > params.flat_curvature) kind[t] = RegionKind::CurvedPositive;
    else if (bending[t] < -params.flat_curvature) kind[t] = RegionKind::CurvedNegative;
  }
  // Connected components of equal kind, seeded in ascending triangle order (deterministic ids).
  // Components smaller than min_region_triangles take the kind of the neighbouring component they
  // share most edges with (noise, not a region of the surface), then components are formed again.
  std::vector<int32_t> stack;
  for (int32_t round = 0; round < 2 && params.min_region_triangles > 1; ++round) {
    std::vector<int32_t> comp(nt, -1);
    std::vector<std::vector<int32_t>> members;
    for (int32_t s0 = 0; s0 < nt; ++s0) {
      if (comp[s0] >= 0) continue;
      const int32_t id = static_cast<int32_t>(members.size());
      members.emplace_back();
      comp[s0] = id;
      stack.push_back(s0);
      while (!stack.empty()) {
        const int32_t t = stack.back();
        stack.pop_back();
        members[id].push_back(t);
        for (int32_t o : topo.neighbor[t])
          if (o >= 0 && comp[o] < 0 && kind[o] == kind[s0]) comp[o] = id, stack.push_back(o);
      }
    }
    bool changed = false;
    for (const auto& m : members) {
      if (static_cast<int32_t>(m.size()) >= params.min_region_triangles) continue;
      int32_t votes[3] = {0, 0, 0};
      for (int32_t t : m)
        for (int32_t o : topo.neighbor[t])
          if (o >= 0 && kind[o] != kind[t]) ++votes[static_cast<int>(kind[o])];
      const int best = static_cast<int>(std::max_element(votes, votes + 3) - votes);
      if (votes[best] == 0) continue;  // a whole piece of its own: keep it
      for (int32_t t : m) kind[t] = static_cast<RegionKind>(best);
      changed = true;
    }
    if (!changed) break;
  }
  tri_region.assign(nt, -1);
  regions.clear();
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
    const std::span<const int32_t> fan = topo.fan(v);
    if (fan.empty()) continue;
    if (topo.boundary_next[v] >= 0) {
      // Junction: the boundary vertex's fan touches regions of different kind (flat/curved or signs).
      const RegionKind k0 = regions[tri_region[fan[0]]].kind;
      bool mixed = false;
      for (size_t k = 1; k < fan.size() && !mixed; ++k) mixed = regions[tri_region[fan[k]]].kind != k0;
      if (mixed) {
        flags[v] |= kJunction;
        ++summary.junctions;
      }
    } else {
      // Interior singular point: bending concentrated at this vertex (a cone apex).
      double peak = 0;
      for (int32_t t : fan) peak = std::max(peak, std::abs(bending[t]));
      if (peak > params.singular_curvature) {
        flags[v] |= kSingular;
        ++summary.singular;
        const int32_t r = tri_region[fan[0]];
        if (regions[r].apex < 0) regions[r].apex = v;
      }
    }
  }
  return summary;
}

}  // namespace pt
