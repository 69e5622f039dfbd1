// papertear-fig19: the reproduction of the paper's Fig. 19 (Schreck et al. 2017, §7.4): the same tear
// carved with two σ and at three texture resolutions, composed into one PNG grid.
//
//   papertear-fig19 SCENARIO_ROW1 SCENARIO_ROW2 [--frames N] [--window MM] [--cell PX] [--out FILE.png]
//
// Each scenario is simulated (deterministic, any thread count) and its longest tear's coarse tips are
// re-carved (systems/carving/carving: detail_path + side labels) at the three resolutions of the paper for an A4
// sheet — 4528 × 3200, 2048 × 1476 and 1169 × 826 over 297 mm, i.e. 65.6, 145 and 254 µm per pixel —
// with the scenario's σ and ω and the same fiber field (seed and feature size) sampled at that resolution.
// Row r = scenario r; columns = resolutions, finest first. Every cell is the same physical window
// (`--window` mm along the tear, centred on its middle), upscaled nearest-neighbour to the same size:
// the left lip's carved paper (paper colour × fibres) over a dark background, the broken-fibre pixels
// of the detailed path in a darker fibre colour. Prints the mean deviation of each detailed path from
// its coarse path (the roughness measure of tests/carving/carving_test.cpp).
#include "engine/scenario.hpp"
#include "engine/sheet_builder.hpp"
#include "engine/simulation.hpp"
#include "engine/texture_export.hpp"
#include "systems/carving/carving.hpp"
#include "systems/tearing/fiber_field.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

namespace {

using pt::Vec2;

constexpr double kA4Width = 0.297;  // m, the long side the paper's resolutions refer to
constexpr std::array<int32_t, 3> kA4Pixels = {4528, 2048, 1169};

double polyline_length(const std::vector<Vec2>& p) {
  double l = 0;
  for (size_t k = 1; k < p.size(); ++k) l += (p[k] - p[k - 1]).norm();
  return l;
}

Vec2 point_at_length(const std::vector<Vec2>& p, double s) {
  for (size_t k = 1; k < p.size(); ++k) {
    const double l = (p[k] - p[k - 1]).norm();
    if (s <= l && l > 0) return p[k - 1] + (p[k] - p[k - 1]) * (s / l);
    s -= l;
  }
  return p.back();
}

// Mean distance of the detail points to the coarse polyline, m.
double mean_deviation(const std::vector<Vec2>& coarse, const std::vector<Vec2>& detail) {
  double sum = 0;
  for (const Vec2& q : detail) {
    double best = INFINITY;
    for (size_t k = 0; k + 1 < coarse.size(); ++k) {
      const Vec2 ab = coarse[k + 1] - coarse[k];
      const double len2 = ab.squaredNorm();
      const double t = len2 > 0 ? std::clamp((q - coarse[k]).dot(ab) / len2, 0.0, 1.0) : 0.0;
      best = std::min(best, (q - (coarse[k] + t * ab)).norm());
    }
    sum += best;
  }
  return detail.empty() ? 0.0 : sum / static_cast<double>(detail.size());
}

struct Row {
  std::string name;
  pt::Scenario scenario;
  std::vector<Vec2> tips;
};

Row simulate(const std::string& path, int32_t frames) {
  Row row;
  row.scenario = pt::load_scenario(path);
  if (frames > 0) row.scenario.sim.frames = frames;
  row.name = row.scenario.name;
  pt::Simulation sim(row.scenario);
  for (int32_t f = 0; f < row.scenario.sim.frames; ++f) sim.step();
  sim.flush();
  double best = 0;
  for (const pt::Tear& t : sim.sheet().tears) {
    const double l = polyline_length(t.tips);
    if (l > best) {
      best = l;
      row.tips = t.tips;
    }
  }
  if (row.tips.size() < 2) throw std::runtime_error(path + ": no tear after " + std::to_string(row.scenario.sim.frames) + " frames");
  return row;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> scenarios;
  std::string out = "docs/fig19-details.png";
  int32_t frames = -1, cell = 480;
  double window_mm = 20.0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "papertear-fig19: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--out") out = value();
    else if (a == "--frames") frames = std::atoi(value().c_str());
    else if (a == "--window") window_mm = std::atof(value().c_str());
    else if (a == "--cell") cell = std::atoi(value().c_str());
    else if (a == "--help" || a == "-h") {
      std::printf("usage: papertear-fig19 SCENARIO_ROW1 SCENARIO_ROW2 [--frames N] [--window MM] [--cell PX] [--out FILE.png]\n");
      return 0;
    } else if (!a.empty() && a[0] == '-') {
      std::fprintf(stderr, "papertear-fig19: unknown option %s\n", a.c_str());
      return 2;
    } else scenarios.push_back(a);
  }
  if (scenarios.empty() || window_mm <= 0 || cell < 16) {
    std::fprintf(stderr, "papertear-fig19: usage: papertear-fig19 SCENARIO... [--frames N] [--window MM] [--cell PX] [--out FILE.png]\n");
    return 2;
  }
  try {
    std::vector<Row> rows;
    for (const std::string& s : scenarios) rows.push_back(simulate(s, frames));
    for (size_t r = 1; r < rows.size(); ++r)
      std::printf("%s and %s: coarse tears %s\n", rows[0].name.c_str(), rows[r].name.c_str(),
                  rows[r].tips == rows[0].tips ? "identical (σ does not feed back into the physics)" : "differ");

    // The window: centred on the middle of the first row's tear, long side along the tear's dominant axis.
    const std::vector<Vec2>& ref = rows[0].tips;
    const Vec2 centre = point_at_length(ref, 0.5 * polyline_length(ref));
    const Vec2 d = ref.back() - ref.front();
    const bool vertical = std::abs(d.y()) >= std::abs(d.x());
    const double along = window_mm * 1e-3, across = 0.6 * along;
    const Vec2 half = vertical ? Vec2(across / 2, along / 2) : Vec2(along / 2, across / 2);
    const Vec2 lo = centre - half, hi = centre + half;
    const int32_t cell_w = vertical ? static_cast<int32_t>(std::lround(cell * 0.6)) : cell;
    const int32_t cell_h = vertical ? cell : static_cast<int32_t>(std::lround(cell * 0.6));
    constexpr int32_t kGap = 6;
    const int32_t cols = static_cast<int32_t>(kA4Pixels.size());
    const int32_t W = cols * cell_w + (cols + 1) * kGap;
    const int32_t H = static_cast<int32_t>(rows.size()) * cell_h + (static_cast<int32_t>(rows.size()) + 1) * kGap;
    std::vector<uint8_t> grid(static_cast<size_t>(W) * H * 4, 255);

    const pt::PatternStyle style;
    const std::array<uint8_t, 3> background{52, 54, 62}, fibre{176, 160, 132};
    std::printf("window: %.1f x %.1f mm centred at (%.1f, %.1f) mm\n", 2e3 * half.x(), 2e3 * half.y(), 1e3 * centre.x(),
                1e3 * centre.y());
    for (size_t r = 0; r < rows.size(); ++r) {
      const pt::Scenario& sc = rows[r].scenario;
      Vec2 blo = sc.outline.front(), bhi = sc.outline.front();
      for (const Vec2& q : sc.outline) blo = blo.cwiseMin(q), bhi = bhi.cwiseMax(q);
      for (int32_t c = 0; c < cols; ++c) {
        // Same per-metre resolution as the paper's A4 texture of kA4Pixels[c] columns.
        pt::FiberField fiber = pt::make_fiber_field(sc);
        pt::DetailParams params;
        params.origin = blo;
        params.pixel_size = kA4Width / kA4Pixels[c];
        params.width = static_cast<int32_t>(std::ceil((bhi.x() - blo.x()) / params.pixel_size));
        params.height = static_cast<int32_t>(std::ceil((bhi.y() - blo.y()) / params.pixel_size));
        params.sigma = sc.detail.sigma;
        params.omega = sc.detail.omega;
        fiber.origin = params.origin;
        fiber.pixel_size = params.pixel_size;  // the same field, sampled at this resolution
        std::vector<pt::Tear> tears(1);
        tears[0].id = 0;
        tears[0].tips = rows[r].tips;
        pt::CarveState state;
        pt::carve_new_segments(fiber, params, tears, state);
        const double dev = mean_deviation(tears[0].tips, tears[0].detail);
        std::printf("%-20s sigma %.2f mm  %4d px/A4 (%5.1f um/px, %dx%d px here): %zu path px, mean deviation %.3f mm, "
                    "label map %lld B\n",
                    rows[r].name.c_str(), sc.detail.sigma * 1e3, kA4Pixels[c], params.pixel_size * 1e6, params.width,
                    params.height, tears[0].detail.size(), dev * 1e3, static_cast<long long>(pt::bytes_used(state)));

        // The window in this texture's pixels, then nearest-neighbour into the cell.
        const pt::Pixel p0 = pt::pixel_of(params, lo), p1 = pt::pixel_of(params, hi);
        const int32_t sw = std::max(1, p1[0] - p0[0] + 1), sh = std::max(1, p1[1] - p0[1] + 1);
        const int32_t left = pt::side_label(0, true);
        std::vector<std::array<uint8_t, 3>> src(static_cast<size_t>(sw) * sh);
        for (int32_t y = 0; y < sh; ++y)
          for (int32_t x = 0; x < sw; ++x) {
            const int32_t i = p0[0] + x, j = p0[1] + y;
            std::array<uint8_t, 3>& px = src[static_cast<size_t>(y) * sw + x];
            const uint16_t l = pt::label_at(state, i, j);
            // Labelled pixels by their label; the rest of the window (outside the carved band) by the side
            // of the nearest coarse segment.
            const bool visible = l != pt::kPaperLabel ? l == left
                                                      : pt::triangle_side(tears[0], pt::pixel_centre(params, i, j)) == left;
            if (l == pt::kPathLabel) px = fibre;
            else if (visible) {
              const double shade = 1.0 + style.fiber * (pt::fiber_texel(fiber, i, j) - 0.5);
              for (int k = 0; k < 3; ++k)
                px[k] = static_cast<uint8_t>(std::clamp(std::lround(style.paper[k] * shade), 0L, 255L));
            } else px = background;
          }
        const int32_t ox = kGap + c * (cell_w + kGap), oy = kGap + static_cast<int32_t>(r) * (cell_h + kGap);
        for (int32_t y = 0; y < cell_h; ++y)
          for (int32_t x = 0; x < cell_w; ++x) {
            const int32_t sx = std::min(sw - 1, x * sw / cell_w);
            const int32_t sy = std::min(sh - 1, (cell_h - 1 - y) * sh / cell_h);  // image rows down, pattern y up
            const auto& s = src[static_cast<size_t>(sy) * sw + sx];
            uint8_t* d = grid.data() + (static_cast<size_t>(oy + y) * W + (ox + x)) * 4;
            d[0] = s[0], d[1] = s[1], d[2] = s[2], d[3] = 255;
          }
      }
    }
    pt::write_rgba_png(out, W, H, grid);
    std::printf("wrote %s (%d x %d: rows %s; columns 4528, 2048, 1169 px per A4 width)\n", out.c_str(), W, H,
                rows.size() == 2 ? "sigma of row 1, row 2" : "one per scenario");
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "papertear-fig19: %s\n", e.what());
    return 1;
  }
}
