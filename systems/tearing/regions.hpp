// The geometric layer (paper §4.1 and Fig. 3, docs/tearing.md "Regions and junctions"), computed from the
// deformed mesh each frame: triangles are flat or curved with the sign of their bending; regions are
// connected components of equal kind; junction points are boundary vertices whose triangles belong to two or
// more regions; interior singular points are interior vertices where bending concentrates (cone apices).
#pragma once

#include "components/sheet.hpp"

namespace pt {

struct RegionParams {
  double flat_curvature = 8.0;       // 1/m: |mean bending| below this is flat (radius > 12.5 cm)
  double singular_curvature = 150.0; // 1/m: bending at an interior vertex above this marks a singular point
  // Neighbour averages of the bending before classification. Off by default: two passes removed the
  // junctions of the Fig. 12/13 scenarios along with the noise (measured); merging small regions is kept.
  int32_t smoothing_passes = 0;
  int32_t min_region_triangles = 6;  // smaller components join their main neighbour (mesh-scale noise)
};

// Signed bending of each triangle: Σ over its interior edges of θ_e·|e| / (2·A₃ᴰ)·½, with θ_e the signed
// dihedral angle (positive when the surface turns towards its normal). Normals follow the pattern's
// counter-clockwise orientation, so signs are consistent over a piece.
void triangle_bending(const std::vector<Vec3>& x, const std::vector<Tri>& tri, const Topology& topo,
                      std::vector<double>& bending);

struct RegionSummary {
  int32_t regions = 0, junctions = 0, singular = 0;
};

// Writes tri_region, regions, and the kJunction / kSingular bits of flags. Returns counts.
RegionSummary classify_regions(const std::vector<Vec3>& x, const std::vector<Tri>& tri, const Topology& topo,
                               const RegionParams& params, std::vector<int32_t>& tri_region,
                               std::vector<Region>& regions, std::vector<uint8_t>& flags);

}  // namespace pt
