// T_fiber: the resistance of the fibre network, a seeded fractal Perlin noise in [0, 1] over the pattern
// (paper §4.2 and eq. 7). Evaluated procedurally, so 1 000 sheets with the same seed share nothing but
// this small struct; `sample` is bilinear in a virtual texture of the given resolution so Ef (eq. 3)
// and the carving texture (eq. 7) read the same values.
#pragma once

#include "components/sheet.hpp"

namespace pt {

struct FiberField {
  uint64_t seed = 1;
  double feature_size = 0.004;  // m, coarsest octave
  int32_t octaves = 5;
  double persistence = 0.5;
  Vec2 origin = Vec2::Zero();   // texture origin in the pattern (outline's bounding box min), m
  double pixel_size = 1e-4;     // m per texel of the virtual texture
};

// Value at texel (i, j) (pixel centres at origin + (i + ½, j + ½) · pixel_size), in [0, 1].
double fiber_texel(const FiberField& f, int32_t i, int32_t j);

// Bilinear sample between texel centres at pattern point (u, v), in [0, 1].
double fiber_sample(const FiberField& f, const Vec2& uv);

// fiber_texel(f, i0 + c, j) for c in [0, count) into out[c], bit-identical, hashing each lattice cell
// once per row (full-texture exports). Additive to the fixed interface.
void fiber_row(const FiberField& f, int32_t j, int32_t i0, int32_t count, double* out);

// Continuous procedural value (no texel grid), in [0, 1].
double fiber_noise(const FiberField& f, const Vec2& uv);

}  // namespace pt
