#pragma once
// Filling one triangle's part of a footprint cell (atlas/footprint_layout.h) from an RGB8 image: the footprint atlas
// fills cells from the colour frame through a per-triangle homography, and the tile baker (tiles/) fills them from a
// keyframe's texture through an affine map. One loop serves both. fill_cell_texels visits the same texels for a
// caller whose colour is not a lookup in one image (a flat colour, a search over another surface).
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>

#include "atlas/footprint_layout.h"
#include "scene/image.h"

namespace rgbdcast {

// An RGB8 image as plain numbers, so that the texel loop keeps them in registers (stores through uint8_t* may alias
// anything, which would make the compiler reload an image's fields for every texel).
struct CellSource {
  const std::uint8_t* data = nullptr;
  size_t stride = 0;  // bytes a row
  int cols = 0, rows = 0;
};
CellSource cell_source(const Image& rgb);  // rgb: 3 channels

// Bilinear RGB lookup at pixel (u, v) (centres at integers), clamped to the image; 8-bit fixed-point weights (within
// one level of the exact interpolation).
void sample_bilinear_rgb(const CellSource& src, double u, double v, std::uint8_t* out);

// Fills the texels of `slot`'s cell that belong to its triangle (the upper part i + j + 1 < S, or the rest for the
// lower one, gutters included) by bilinear lookups (8-bit fixed-point weights, clamped to the image) in `src` at
// image_from_atlas * (texel centre, 1) (homogeneous; image pixel centres at integers), and marks them in `sampled`
// (atlas width x height). A texel whose homogeneous w is not above 1e-9 |w of fallback| takes the pixel at
// fallback_px (a continued plane that passes behind the camera).
void fill_cell_triangle(const FootprintSlot& slot, const Eigen::Matrix3d& image_from_atlas,
                        const Eigen::Vector3d& fallback_h, const CellSource& src, Image* atlas, std::uint8_t* sampled);

// Calls colour_at(x, y, rgb) for every texel of `slot`'s triangle (the texels fill_cell_triangle fills), with (x, y)
// the texel's centre in atlas coordinates (texel (i, j) covers [i, i+1]^2) and rgb its 3 bytes in `atlas` (RGB8), and
// marks them in `sampled` (atlas width x height).
template <class ColourAt>
void fill_cell_texels(const FootprintSlot& slot, Image* atlas, std::uint8_t* sampled, ColourAt&& colour_at) {
  const int S = slot.cell_px;
  for (int j = 0; j < S; ++j) {
    const int split = S - 1 - j;  // texels i < split are the upper triangle's
    const int i0 = slot.lower ? split : 0, i1 = slot.lower ? S : split;
    const size_t row = static_cast<size_t>(slot.y0 + j) * atlas->width + slot.x0;
    for (int i = i0; i < i1; ++i) {
      colour_at(slot.x0 + i + 0.5, slot.y0 + j + 0.5, atlas->data.data() + 3 * (row + i));
      sampled[row + i] = 1;
    }
  }
}

}  // namespace rgbdcast
