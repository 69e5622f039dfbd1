// PNG output of the paper texture and its carving (paper §6.2, §7.4; docs/architecture.md "Details").
#include "engine/texture_export.hpp"

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <png.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <system_error>

namespace pt {
namespace {

PixelRect clip(const PixelRect& r, const DetailParams& p) {
  if (r.width <= 0 || r.height <= 0) return {0, 0, p.width, p.height};
  const int32_t x0 = std::clamp(r.x, 0, p.width), y0 = std::clamp(r.y, 0, p.height);
  const int32_t x1 = std::clamp(r.x + r.width, 0, p.width), y1 = std::clamp(r.y + r.height, 0, p.height);
  return {x0, y0, x1 - x0, y1 - y0};
}

// Pixel columns [begin, end) of texture row j whose centres are inside the outline (even-odd rule on
// the row's centre line): a scanline fill, so the base layer costs O(pixels + rows × outline).
void outline_spans(const std::vector<Vec2>& outline, const DetailParams& p, int32_t j,
                   std::vector<double>& xs, std::vector<std::pair<int32_t, int32_t>>& spans) {
  spans.clear();
  if (outline.size() < 3) {
    spans.push_back({0, p.width});
    return;
  }
  const double yc = p.origin.y() + (j + 0.5) * p.pixel_size;
  xs.clear();
  for (size_t k = 0; k < outline.size(); ++k) {
    const Vec2& a = outline[k];
    const Vec2& b = outline[(k + 1) % outline.size()];
    if ((a.y() <= yc) != (b.y() <= yc)) xs.push_back(a.x() + (yc - a.y()) * (b.x() - a.x()) / (b.y() - a.y()));
  }
  std::sort(xs.begin(), xs.end());
  for (size_t k = 0; k + 1 < xs.size(); k += 2) {
    const auto col = [&](double x) {
      return std::clamp(static_cast<int32_t>(std::ceil((x - p.origin.x()) / p.pixel_size - 0.5)), 0, p.width);
    };
    const int32_t b = col(xs[k]), e = col(xs[k + 1]);
    if (e > b) spans.push_back({b, e});
  }
}

uint8_t to_byte(double v) { return static_cast<uint8_t>(std::clamp(std::lround(v), 0L, 255L)); }

void blend(uint8_t* px, const std::array<uint8_t, 3>& c, double w) {
  for (int k = 0; k < 3; ++k) px[k] = to_byte((1.0 - w) * px[k] + w * c[k]);
}

// Base layer: paper modulated by T_fiber inside the outline, `outside` (RGBA) elsewhere. Rows in
// parallel (each row is independent, so the image does not depend on the thread count).
void render_paper(const std::vector<Vec2>& outline, const DetailParams& p, const FiberField& fiber,
                  const PixelRect& r, const PatternStyle& style, const std::array<uint8_t, 4>& outside,
                  std::vector<uint8_t>& rgba) {
  rgba.assign(static_cast<size_t>(r.width) * static_cast<size_t>(r.height) * 4, 0);
  const bool same_grid = fiber.origin == p.origin && fiber.pixel_size == p.pixel_size;
  tbb::parallel_for(tbb::blocked_range<int32_t>(0, r.height, 16), [&](const tbb::blocked_range<int32_t>& rows) {
    std::vector<double> xs, fibre(static_cast<size_t>(r.width));
    std::vector<std::pair<int32_t, int32_t>> spans;
    for (int32_t row = rows.begin(); row < rows.end(); ++row) {
      const int32_t j = r.y + r.height - 1 - row;  // image row 0 is the top of the pattern
      uint8_t* line = rgba.data() + static_cast<size_t>(row) * static_cast<size_t>(r.width) * 4;
      for (int32_t c = 0; c < r.width; ++c) std::copy(outside.begin(), outside.end(), line + 4 * c);
      outline_spans(outline, p, j, xs, spans);
      if (same_grid && !spans.empty()) fiber_row(fiber, j, r.x, r.width, fibre.data());
      for (const auto& [b, e] : spans)
        for (int32_t i = std::max(b, r.x); i < std::min(e, r.x + r.width); ++i) {
          const double t = same_grid ? fibre[static_cast<size_t>(i - r.x)] : fiber_sample(fiber, pixel_centre(p, i, j));
          const double shade = 1.0 + style.fiber * (t - 0.5);
          uint8_t* px = line + 4 * (i - r.x);
          for (int k = 0; k < 3; ++k) px[k] = to_byte(style.paper[k] * shade);
          px[3] = 255;
        }
    }
  });
}

// Visit the labelled pixels of the sparse map inside r: f(image pointer, label). Only touched tiles are
// visited, so overlays cost O(tear neighbourhood), not O(texture).
template <class F>
void for_each_label(const CarveState& state, const PixelRect& r, std::vector<uint8_t>& rgba, F&& f) {
  for (size_t k = 0; k < state.tile_keys.size(); ++k) {
    const int32_t tx = static_cast<int32_t>(state.tile_keys[k] & 0xFFFF);
    const int32_t ty = static_cast<int32_t>(state.tile_keys[k] >> 16);
    const LabelTile& tile = *state.tiles[static_cast<size_t>(state.tile_slot[k])];
    for (int32_t ly = 0; ly < kTileSize; ++ly) {
      const int32_t j = ty * kTileSize + ly;
      if (j < r.y || j >= r.y + r.height) continue;
      const int32_t row = r.y + r.height - 1 - j;
      for (int32_t lx = 0; lx < kTileSize; ++lx) {
        const int32_t i = tx * kTileSize + lx;
        if (i < r.x || i >= r.x + r.width) continue;
        const uint16_t l = tile.label[static_cast<size_t>(ly * kTileSize + lx)];
        if (l == kPaperLabel) continue;
        f(rgba.data() + (static_cast<size_t>(row) * static_cast<size_t>(r.width) + static_cast<size_t>(i - r.x)) * 4, l);
      }
    }
  }
}

// libpng's default handlers print their own line on stderr ("libpng error: Write Error") before the
// caller's one-line message; these keep the text for the exception instead. A failed write's errno (ENOSPC
// on a full disk) is kept with it: "Write Error" alone does not say why.
void keep_png_error(png_structp png, png_const_charp message) {
  const int error = errno;
  std::string& kept = *static_cast<std::string*>(png_get_error_ptr(png));
  kept = message;
  if (error != 0) kept += " (" + std::generic_category().message(error) + ")";
  png_longjmp(png, 1);
}

// A warning is not a failure (the file is still written): nothing to say.
void ignore_png_warning(png_structp, png_const_charp) {}

}  // namespace

void write_rgba_png(const std::string& path, int32_t width, int32_t height, const uint8_t* rgba) {
  if (width <= 0 || height <= 0) throw std::runtime_error(path + ": empty image");
  FILE* file = std::fopen(path.c_str(), "wb");
  if (!file) throw std::runtime_error(path + ": cannot open for writing");
  std::string png_error_message;  // set by keep_png_error before it jumps back to the setjmp below
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &png_error_message, keep_png_error,
                                            ignore_png_warning);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) {
    png_destroy_write_struct(&png, nullptr);
    std::fclose(file);
    throw std::runtime_error(path + ": libpng initialisation failed");
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    std::fclose(file);
    throw std::runtime_error(path + ": PNG write failed: " + png_error_message);
  }
  errno = 0;
  png_init_io(png, file);
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height), 8, PNG_COLOR_TYPE_RGBA,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  // Fast settings: a 2048 × 1476 texture must write well under a second; paper with fibres compresses
  // little better at higher levels anyway.
  png_set_compression_level(png, 1);
  png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_UP);
  png_write_info(png, info);
  for (int32_t row = 0; row < height; ++row)
    png_write_row(png, const_cast<png_bytep>(rgba + static_cast<size_t>(row) * static_cast<size_t>(width) * 4));
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  if (std::fclose(file) != 0) throw std::runtime_error(path + ": write failed: " + std::generic_category().message(errno));
}

void write_rgba_png(const std::string& path, int32_t width, int32_t height, const std::vector<uint8_t>& rgba) {
  if (rgba.size() < static_cast<size_t>(width) * static_cast<size_t>(height) * 4)
    throw std::runtime_error(path + ": RGBA buffer smaller than the image");
  write_rgba_png(path, width, height, rgba.data());
}

PixelRect render_pattern_rgba(const std::vector<Vec2>& outline, const std::vector<Tear>& tears,
                              const CarveState& state, const DetailParams& params, const FiberField& fiber,
                              const PixelRect& rect, const PatternStyle& style, std::vector<uint8_t>& rgba) {
  const PixelRect r = clip(rect, params);
  const std::array<uint8_t, 4> bg{style.background[0], style.background[1], style.background[2], 255};
  render_paper(outline, params, fiber, r, style, bg, rgba);
  for_each_label(state, r, rgba, [&](uint8_t* px, uint16_t l) {
    if (l == kPathLabel) std::copy(style.path.begin(), style.path.end(), px);
    else blend(px, label_is_left(l) ? style.left_tint : style.right_tint, style.tint);
  });
  // The detail polylines too: consecutive points are 8-connected pixels, so their pixels draw the path
  // even where the label map does not hold it (a tear id beyond the label range).
  for (const Tear& t : tears)
    for (const Vec2& q : t.detail) {
      const Pixel px = pixel_of(params, q);
      if (px[0] < r.x || px[0] >= r.x + r.width || px[1] < r.y || px[1] >= r.y + r.height) continue;
      const size_t row = static_cast<size_t>(r.y + r.height - 1 - px[1]);
      uint8_t* d = rgba.data() + (row * static_cast<size_t>(r.width) + static_cast<size_t>(px[0] - r.x)) * 4;
      std::copy(style.path.begin(), style.path.end(), d);
      d[3] = 255;
    }
  return r;
}

void write_pattern_png(const std::string& path, const std::vector<Vec2>& outline, const std::vector<Tear>& tears,
                       const CarveState& state, const DetailParams& params, const FiberField& fiber,
                       const PixelRect& rect, const PatternStyle& style) {
  std::vector<uint8_t> rgba;
  const PixelRect r = render_pattern_rgba(outline, tears, state, params, fiber, rect, style, rgba);
  write_rgba_png(path, r.width, r.height, rgba);
}

void render_carved_texture_rgba(const std::vector<Vec2>& outline, const CarveState& state, const DetailParams& params,
                                const FiberField& fiber, int32_t side, const PatternStyle& style,
                                std::vector<uint8_t>& rgba) {
  const PixelRect r = clip({}, params);
  render_paper(outline, params, fiber, r, style, {0, 0, 0, 0}, rgba);
  if (side <= 0) return;
  // Same rule as pixel_visible: hide the other side of this side's tear only.
  const int32_t tear = label_tear(side);
  for_each_label(state, r, rgba, [&](uint8_t* px, uint16_t l) {
    if (l != kPathLabel && label_tear(l) == tear && l != side) px[3] = 0;
  });
}

void write_carved_texture_png(const std::string& path, const std::vector<Vec2>& outline, const CarveState& state,
                              const DetailParams& params, const FiberField& fiber, int32_t side,
                              const PatternStyle& style) {
  std::vector<uint8_t> rgba;
  render_carved_texture_rgba(outline, state, params, fiber, side, style, rgba);
  write_rgba_png(path, params.width, params.height, rgba);
}

void read_rgba_png(const std::string& path, int32_t& width, int32_t& height, std::vector<uint8_t>& rgba) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&image, path.c_str()))
    throw std::runtime_error(path + ": " + image.message);
  image.format = PNG_FORMAT_RGBA;
  rgba.assign(PNG_IMAGE_SIZE(image), 0);
  if (!png_image_finish_read(&image, nullptr, rgba.data(), 0, nullptr)) {
    const std::string message = image.message;
    png_image_free(&image);
    throw std::runtime_error(path + ": " + message);
  }
  width = static_cast<int32_t>(image.width);
  height = static_cast<int32_t>(image.height);
}

const AtlasPatch* CarvedAtlas::find(int32_t label) const {
  for (const AtlasPatch& p : patches)
    if (p.label == label) return &p;
  return nullptr;
}

Vec2 CarvedAtlas::uv(const DetailParams& params, const AtlasPatch& patch, const Vec2& p) const {
  const Vec2 q = (p - params.origin) / params.pixel_size;  // texture pixels, y up
  const double ax = patch.x + (q.x() - patch.rect.x);
  const double ay = patch.y + (patch.rect.y + patch.rect.height - q.y());  // atlas rows, down
  return {ax / std::max(1, width), 1.0 - ay / std::max(1, height)};
}

bool CarvedAtlas::operator==(const CarvedAtlas& o) const {
  if (width != o.width || height != o.height || patches.size() != o.patches.size()) return false;
  for (size_t k = 0; k < patches.size(); ++k) {
    const AtlasPatch &a = patches[k], &b = o.patches[k];
    if (a.label != b.label || a.x != b.x || a.y != b.y || a.rect.x != b.rect.x || a.rect.y != b.rect.y ||
        a.rect.width != b.rect.width || a.rect.height != b.rect.height)
      return false;
  }
  return true;
}

CarvedAtlas pack_carved_atlas(const std::vector<std::pair<int32_t, PixelRect>>& windows, int32_t max_width) {
  CarvedAtlas atlas;
  int32_t limit = max_width;
  for (const auto& [label, r] : windows) limit = std::max(limit, r.width);
  int32_t x = 0, y = 0, shelf = 0;
  for (const auto& [label, r] : windows) {
    if (r.width <= 0 || r.height <= 0) continue;
    if (x > 0 && x + r.width > limit) {  // next shelf
      y += shelf;
      x = 0;
      shelf = 0;
    }
    atlas.patches.push_back({label, r, x, y});
    x += r.width;
    shelf = std::max(shelf, r.height);
    atlas.width = std::max(atlas.width, x);
  }
  atlas.height = y + shelf;
  return atlas;
}

bool side_pixel_visible(const std::vector<Tear>& tears, const CarveState& state, const DetailParams& params,
                        int32_t label, int32_t i, int32_t j, double reach) {
  if (label <= 0) return true;
  const int32_t tear = label_tear(label);
  const uint16_t l = label_at(state, i, j);
  if (l == kPathLabel) return true;
  if (l != kPaperLabel) return label_tear(l) != tear || l == label;
  if (tear < 0 || tear >= static_cast<int32_t>(tears.size())) return true;
  // Unlabelled: across the coarse path (projecting inside one of its segments, within reach)?
  const Tear& t = tears[static_cast<size_t>(tear)];
  const Vec2 c = pixel_centre(params, i, j);
  double best = reach * reach;
  int64_t found = -1;
  for (size_t s = 0; s + 1 < t.tips.size(); ++s) {
    const Vec2 ab = t.tips[s + 1] - t.tips[s];
    const double len2 = ab.squaredNorm();
    if (len2 <= 0) continue;
    const double u = (c - t.tips[s]).dot(ab) / len2;
    if (u < 0 || u > 1) continue;
    const double d2 = (c - (t.tips[s] + u * ab)).squaredNorm();
    if (d2 < best) {
      best = d2;
      found = static_cast<int64_t>(s);
    }
  }
  if (found < 0) return true;
  const Vec2 ab = t.tips[found + 1] - t.tips[found], ac = c - t.tips[found];
  return side_label(tear, ab.x() * ac.y() - ab.y() * ac.x() > 0) == label;
}

void render_carved_atlas(const CarvedAtlas& atlas, const std::vector<Vec2>& outline, const std::vector<Tear>& tears,
                         const CarveState& state, const DetailParams& params, const FiberField& fiber,
                         const PatternStyle& style, std::vector<uint8_t>& rgba) {
  rgba.assign(static_cast<size_t>(atlas.width) * static_cast<size_t>(atlas.height) * 4, 0);
  const double reach = 2.0 * support_strip_width(params) + 2.0 * params.pixel_size;
  std::vector<uint8_t> patch;
  for (const AtlasPatch& p : atlas.patches) {
    const PixelRect r = clip(p.rect, params);
    if (r.width != p.rect.width || r.height != p.rect.height) throw std::runtime_error("atlas patch outside the texture");
    render_paper(outline, params, fiber, r, style, {0, 0, 0, 0}, patch);
    tbb::parallel_for(tbb::blocked_range<int32_t>(0, r.height, 16), [&](const tbb::blocked_range<int32_t>& rows) {
      for (int32_t row = rows.begin(); row < rows.end(); ++row) {
        const int32_t j = r.y + r.height - 1 - row;
        const uint8_t* src = patch.data() + static_cast<size_t>(row) * static_cast<size_t>(r.width) * 4;
        uint8_t* dst = rgba.data() + (static_cast<size_t>(p.y + row) * static_cast<size_t>(atlas.width) +
                                      static_cast<size_t>(p.x)) * 4;
        std::copy(src, src + static_cast<size_t>(r.width) * 4, dst);
        for (int32_t c = 0; c < r.width; ++c)
          if (dst[4 * c + 3] != 0 && !side_pixel_visible(tears, state, params, p.label, r.x + c, j, reach))
            dst[4 * c + 3] = 0;
      }
    });
  }
}

}  // namespace pt
