#include "atlas/cell_fill.h"

#include <algorithm>

namespace rgbdcast {
namespace {

// Bilinear RGB lookup at pixel (u, v) (centres at integers), clamped to the image; 8-bit fixed-point weights (the
// result is within one level of the exact interpolation), integer arithmetic throughout.
inline void sample_rgb(const CellSource& s, double max_u, double max_v, double u, double v, std::uint8_t* out) {
  u = std::min(std::max(u, 0.0), max_u);
  v = std::min(std::max(v, 0.0), max_v);
  const int x0 = static_cast<int>(u), y0 = static_cast<int>(v);
  const int dx = x0 + 1 < s.cols ? 3 : 0;
  const size_t dy = y0 + 1 < s.rows ? s.stride : 0;
  const int wx = static_cast<int>((u - x0) * 256.0 + 0.5), wy = static_cast<int>((v - y0) * 256.0 + 0.5);
  const std::uint8_t* p = s.data + y0 * s.stride + 3 * x0;
  const std::uint8_t* q = p + dy;
  int rgb[3];
  for (int c = 0; c < 3; ++c) {
    const int top = (p[c] << 8) + wx * (p[c + dx] - p[c]);
    const int bot = (q[c] << 8) + wx * (q[c + dx] - q[c]);
    rgb[c] = ((top << 8) + wy * (bot - top) + (1 << 15)) >> 16;
  }
  out[0] = static_cast<std::uint8_t>(rgb[0]);
  out[1] = static_cast<std::uint8_t>(rgb[1]);
  out[2] = static_cast<std::uint8_t>(rgb[2]);
}

}  // namespace

void sample_bilinear_rgb(const CellSource& src, double u, double v, std::uint8_t* out) {
  sample_rgb(src, src.cols - 1.0, src.rows - 1.0, u, v, out);
}

CellSource cell_source(const Image& rgb) {
  return {rgb.data.data(), static_cast<size_t>(rgb.width) * 3, rgb.width, rgb.height};
}

void fill_cell_triangle(const FootprintSlot& slot, const Eigen::Matrix3d& M, const Eigen::Vector3d& c,
                        const CellSource& src, Image* atlas, std::uint8_t* sampled) {
  const int S = slot.cell_px;
  const double max_u = src.cols - 1.0, max_v = src.rows - 1.0;
  const double cu = c.x() / c.z(), cv = c.y() / c.z(), min_w = 1e-9 * std::abs(c.z());
  const double sx = M(0, 0), sy = M(1, 0), sz = M(2, 0);
  const int width = atlas->width;
  std::uint8_t* const texels = atlas->data.data();
  for (int j = 0; j < S; ++j) {
    const int split = S - 1 - j;  // texels i < split are the upper triangle's
    const int i0 = slot.lower ? split : 0, i1 = slot.lower ? S : split;
    const Eigen::Vector3d h0 = M * Eigen::Vector3d(slot.x0 + i0 + 0.5, slot.y0 + j + 0.5, 1.0);
    double hx = h0.x(), hy = h0.y(), hz = h0.z();
    const size_t row = static_cast<size_t>(slot.y0 + j) * width + slot.x0;
    std::uint8_t* px = texels + 3 * (row + i0);
    std::fill(sampled + row + i0, sampled + row + i1, std::uint8_t{1});
    for (int i = i0; i < i1; ++i, hx += sx, hy += sy, hz += sz, px += 3) {
      if (hz > min_w) {
        const double inv = 1.0 / hz;
        sample_rgb(src, max_u, max_v, hx * inv, hy * inv, px);
      } else {
        sample_rgb(src, max_u, max_v, cu, cv, px);
      }
    }
  }
}

}  // namespace rgbdcast
