// T_fiber (paper §4.2, eq. 3 and eq. 7): seeded fractal Perlin gradient noise, evaluated procedurally.
//
// Lattice gradients come from an integer hash of (seed, octave, lattice corner) rather than from a
// permutation table: a table would have to be built per seed and held per sheet, while the hash needs no
// state at all, so a batch of 1 000 sheets shares nothing but each FiberField's few bytes.
#include "systems/tearing/fiber_field.hpp"

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>

namespace pt {
namespace {

// splitmix64 finaliser: a cheap, well mixed 64-bit integer hash (Steele et al. 2014).
inline uint64_t mix64(uint64_t z) {
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// 32 unit gradient directions. The table is the same for every seed (the seed only picks entries), so
// it is not per-sheet state; 32 directions avoid the axis-aligned look of Perlin's original 4–8.
struct GradientTable {
  std::array<double, 32> gx{}, gy{};
  GradientTable() {
    for (int k = 0; k < 32; ++k) {
      const double a = (k + 0.5) * (2.0 * M_PI / 32.0);
      gx[k] = std::cos(a);
      gy[k] = std::sin(a);
    }
  }
};
const GradientTable& gradients() {
  static const GradientTable table;
  return table;
}

// Quintic fade 6t⁵ − 15t⁴ + 10t³ (Perlin 2002): C² so the field and its bilinear texture have no
// visible lattice creases.
inline double fade(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }

// Gradient index of a lattice corner: one splitmix finaliser, the lattice coordinates folded in with
// odd multipliers first (a bijection per coordinate), the avalanche makes neighbouring corners independent.
inline int corner_gradient(uint64_t key, int64_t ix, int64_t iy) {
  const uint64_t h = mix64(key + static_cast<uint64_t>(ix) * 0xD1B54A32D192ED03ull +
                           static_cast<uint64_t>(iy) * 0x8CB92BA72F3D8DD7ull);
  return static_cast<int>(h >> 59);  // top 5 bits: 32 directions
}

// One octave of 2D Perlin noise inside a lattice cell with corner gradients k00..k11 at offset (dx, dy)
// from its lower-left corner; roughly in [−0.71, 0.71], mean 0. fiber_noise and fiber_row share it so
// both give the same bits.
inline double perlin_cell(const GradientTable& g, int k00, int k10, int k01, int k11, double dx, double dy) {
  const double n00 = g.gx[k00] * dx + g.gy[k00] * dy;
  const double n10 = g.gx[k10] * (dx - 1.0) + g.gy[k10] * dy;
  const double n01 = g.gx[k01] * dx + g.gy[k01] * (dy - 1.0);
  const double n11 = g.gx[k11] * (dx - 1.0) + g.gy[k11] * (dy - 1.0);
  const double u = fade(dx), v = fade(dy);
  const double a = n00 + u * (n10 - n00);
  const double b = n01 + u * (n11 - n01);
  return a + v * (b - a);
}

inline double perlin(const GradientTable& g, uint64_t key, double x, double y) {
  const double fx = std::floor(x), fy = std::floor(y);
  const int64_t ix = static_cast<int64_t>(fx), iy = static_cast<int64_t>(fy);
  return perlin_cell(g, corner_gradient(key, ix, iy), corner_gradient(key, ix + 1, iy),
                     corner_gradient(key, ix, iy + 1), corner_gradient(key, ix + 1, iy + 1), x - fx, y - fy);
}

// Per-octave constants: its own hash key (unrelated gradients) and a lattice offset so the lattice
// corners of successive octaves do not coincide (no zero-crossing grid).
struct Octave {
  uint64_t key;
  double off_x, off_y;
};
inline Octave octave(const FiberField& f, int32_t o) {
  const uint64_t key = mix64(f.seed * 0x9E3779B97F4A7C15ull + static_cast<uint64_t>(o) + 1);
  return {key, static_cast<double>(key & 0xFFFF) / 65536.0 * 17.0,
          static_cast<double>((key >> 16) & 0xFFFF) / 65536.0 * 17.0};
}

// The fractal sum divided by the sum of amplitudes has a standard deviation of about 0.12 (5 octaves,
// persistence 0.5); this gain maps it to mean 0.5, std 0.25, with ~2 % of values clamped at each end,
// so Ef (eq. 3) varies by a useful factor and the detail path (eq. 7) sees real contrast.
constexpr double kGain = 2.0;

}  // namespace

double fiber_noise(const FiberField& f, const Vec2& uv) {
  const GradientTable& g = gradients();
  const int32_t octaves = std::max<int32_t>(1, f.octaves);
  const double base = 1.0 / std::max(f.feature_size, 1e-12);
  double freq = base, amp = 1.0, sum = 0.0, norm = 0.0;
  for (int32_t o = 0; o < octaves; ++o) {
    const Octave oc = octave(f, o);
    sum += amp * perlin(g, oc.key, uv.x() * freq + oc.off_x, uv.y() * freq + oc.off_y);
    norm += amp;
    amp *= f.persistence;
    freq *= 2.0;
  }
  const double n = norm > 0 ? sum / norm : 0.0;
  return std::clamp(0.5 + kGain * n, 0.0, 1.0);
}

void fiber_row(const FiberField& f, int32_t j, int32_t i0, int32_t count, double* out) {
  // Same arithmetic as fiber_texel, octave by octave over the row: the corner gradients are hashed once
  // per lattice cell instead of once per texel (a cell of the finest default octave spans ~2.5 texels,
  // the coarsest ~40), which is what makes full-texture PNG exports cheap.
  if (count <= 0) return;
  const GradientTable& g = gradients();
  const int32_t octaves = std::max<int32_t>(1, f.octaves);
  const double base = 1.0 / std::max(f.feature_size, 1e-12);
  const double cy = f.origin.y() + (j + 0.5) * f.pixel_size;
  std::fill(out, out + count, 0.0);
  double freq = base, amp = 1.0, norm = 0.0;
  for (int32_t o = 0; o < octaves; ++o) {
    const Octave oc = octave(f, o);
    const double y = cy * freq + oc.off_y;
    const double fy = std::floor(y);
    const int64_t iy = static_cast<int64_t>(fy);
    const double dy = y - fy;
    int64_t cell = INT64_MIN;
    int k00 = 0, k10 = 0, k01 = 0, k11 = 0;
    for (int32_t c = 0; c < count; ++c) {
      const double cx = f.origin.x() + (i0 + c + 0.5) * f.pixel_size;
      const double x = cx * freq + oc.off_x;
      const double fx = std::floor(x);
      const int64_t ix = static_cast<int64_t>(fx);
      if (ix != cell) {
        cell = ix;
        k00 = corner_gradient(oc.key, ix, iy);
        k10 = corner_gradient(oc.key, ix + 1, iy);
        k01 = corner_gradient(oc.key, ix, iy + 1);
        k11 = corner_gradient(oc.key, ix + 1, iy + 1);
      }
      out[c] += amp * perlin_cell(g, k00, k10, k01, k11, x - fx, dy);
    }
    norm += amp;
    amp *= f.persistence;
    freq *= 2.0;
  }
  for (int32_t c = 0; c < count; ++c) {
    const double n = norm > 0 ? out[c] / norm : 0.0;
    out[c] = std::clamp(0.5 + kGain * n, 0.0, 1.0);
  }
}

double fiber_texel(const FiberField& f, int32_t i, int32_t j) {
  const Vec2 centre = f.origin + Vec2((i + 0.5) * f.pixel_size, (j + 0.5) * f.pixel_size);
  return fiber_noise(f, centre);
}

double fiber_sample(const FiberField& f, const Vec2& uv) {
  // Texel centres sit at half-integer texel coordinates: shift by ½ so (i0, j0) is the lower-left centre.
  const double x = (uv.x() - f.origin.x()) / f.pixel_size - 0.5;
  const double y = (uv.y() - f.origin.y()) / f.pixel_size - 0.5;
  const double fx = std::floor(x), fy = std::floor(y);
  const int32_t i0 = static_cast<int32_t>(fx), j0 = static_cast<int32_t>(fy);
  const double tx = x - fx, ty = y - fy;
  const double t00 = fiber_texel(f, i0, j0);
  const double t10 = fiber_texel(f, i0 + 1, j0);
  const double t01 = fiber_texel(f, i0, j0 + 1);
  const double t11 = fiber_texel(f, i0 + 1, j0 + 1);
  const double a = t00 + tx * (t10 - t00);
  const double b = t01 + tx * (t11 - t01);
  return a + ty * (b - a);
}

}  // namespace pt
