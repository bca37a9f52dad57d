#pragma once
// Where each triangle's texture goes in the atlas: fixed-size square cells on a grid, row by row, two triangles per
// cell (the upper-left one and the lower-right one, flipped) unless disabled.
//
// Cell of S texels with gutter g, in cell-relative continuous coordinates (texel (i, j) covers [i, i+1] x [j, j+1]):
//   upper triangle: v0 (g, g), v1 (S-2g-1, g), v2 (g, S-2g-1)      hypotenuse on x + y = S - g - 1
//   lower triangle: v0 (S-g, S-g), v1 (2g, S-g), v2 (S-g, 2g)      hypotenuse on x + y = S + g
// A texel belongs to the upper triangle when its centre has x + y < S - 0.5, else to the lower one; every texel of a
// cell is filled from its owner's homography continued past the triangle's edges (the gutter). Bilinear lookups
// inside a triangle then only touch texels of the same triangle when g >= 1 (a lookup reaches under one texel in x
// and in y), so neither filtering nor a neighbour's colour bleeds in. With S a multiple of 8, cells align with
// JPEG's 8x8 luma blocks.
#include <Eigen/Core>
#include <array>
#include <cstddef>

namespace rgbdcast {

struct CellLayout {
  int cell_px = 8;
  int gutter_px = 1;
  bool two_per_cell = true;
  int columns = 0, rows = 0;  // of cells
  int width = 0, height = 0;  // atlas size in texels
  size_t cells = 0;

  // Cell-relative corners of slot k's triangle (v0, v1, v2), in atlas coordinates.
  std::array<Eigen::Vector2d, 3> corners(size_t slot) const;
  // Top-left texel of the cell holding slot k, and whether the slot is the lower triangle of its cell.
  void cell_of(size_t slot, int* x0, int* y0, bool* lower) const;
  // Smallest legs (texels) a triangle gets: the upper triangle's.
  int leg_px() const;
};

// The corners (v0, v1, v2) of a triangle in the square cell of side cell_px whose top-left texel is (x0, y0), in atlas
// coordinates: the upper triangle, the lower one, or (single) one triangle alone in the cell, as described above.
// Shared by the fixed grid and the footprint layout (footprint_layout.h).
std::array<Eigen::Vector2d, 3> cell_triangle_corners(int x0, int y0, int cell_px, int gutter_px, bool two_per_cell,
                                                     bool lower);

// A near-square grid for `triangles` slots. Returns false when the parameters leave no room for a triangle
// (cell_px < 3 g + 2) or the atlas would exceed max_side texels per side.
bool make_cell_layout(size_t triangles, int cell_px, int gutter_px, bool two_per_cell, int max_side, CellLayout* out);

}  // namespace rgbdcast
