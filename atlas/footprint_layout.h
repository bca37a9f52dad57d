#pragma once
// Where each triangle's texture goes in the footprint atlas (TextureMode::kFootprint): square cells sized to the
// triangle's footprint in the colour image, two triangles of the same size class per cell (upper + lower, the cell
// geometry of atlas_layout.h with its gutter), all cells shelf-packed into one image.
//
// Diamonds: two triangles that share their hypotenuse (the edge opposite the right angle: an RTIN's diamond, a square
// in the image) can share one cell without a gutter between them, S = n + 2 g: the cell is then the image square,
// continuous across the diagonal (both triangles' maps agree on the shared edge), so a lookup near the diagonal that
// reads the partner's texels reads the same surface. Other triangles pair up as upper + lower with the gutter between.
//
// Size classes: a triangle needs legs of n texels, n the smallest class >= its footprint (see footprint_leg_px). The
// classes are ceil(2^(k/2)): 1, 2, 3, 4, 6, 8, 12, 16, 23, 32, 46, 64, 91, 128, 182, 256, i.e. the legs of a
// right-triangulated irregular network (1..64 px, axis-aligned or diagonal) rounded up to whole texels, so an RTIN
// triangle gets about one texel per source pixel along each leg. The cell of class n is S = n + 3 g + 1 texels square
// (the upper triangle's legs are n, the lower one's n + 1; atlas_layout.h).
//
// Packing: cells (and any patches, rectangles) sorted by height, tallest first (ties keep the triangle order, so
// neighbours in the mesh sit next to each other in the atlas), placed left to right on shelves as high as the shelf's
// first cell; a smaller cell stacks in a column inside the current shelf while it fits. The width is chosen for a
// near-square atlas; width and height are multiples of 8 (JPEG blocks). Deterministic: the same input gives the same
// layout.
#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace rgbdcast {

// Leg classes in texels, ascending.
const std::vector<int>& footprint_leg_classes();
// The smallest class >= leg_px (with 1e-3 px of slack for rounding), the largest class beyond it; 1 for leg_px <= 1.
int footprint_leg_class(double leg_px);
// The footprint of a projected triangle, as the leg its right isosceles cell needs so that no direction of the triangle
// gets less than one texel per pixel: the largest singular value of [p1 - p0, p2 - p0] (pixels), where p0 is the
// projection of the vertex that goes to the cell's right-angle corner. For a right isosceles image triangle with legs
// L and p0 at its right angle this is L. Also returns (in *right_angle) the vertex with the largest image angle, which
// should be p0.
double footprint_leg_px(const std::array<Eigen::Vector2d, 3>& image_px, int* right_angle);

// One triangle to lay out: its leg class, and its diamond partner (the triangle sharing its hypotenuse), if any.
struct FootprintTriangle {
  int leg = 1;                        // texels (footprint_leg_class)
  std::int64_t diamond_partner = -1;  // index of the partner, which must name this one back; -1 for none
  // For the second triangle of a diamond (the higher index): true when its v1 is the first one's v1 (so its legs run
  // the other way round in the cell).
  bool swapped = false;
};

struct FootprintSlot {
  int x0 = 0, y0 = 0;    // top-left texel of the cell
  int cell_px = 0;       // side of the (square) cell
  bool lower = false;    // the cell's lower triangle (else upper)
  bool paired = false;   // the cell holds two triangles
  bool diamond = false;  // the two share their hypotenuse (no gutter between them)
  bool swapped = false;  // see FootprintTriangle
};

struct FootprintLayout {
  int gutter_px = 1;
  int width = 0, height = 0;         // atlas size in texels (multiples of 8)
  std::vector<FootprintSlot> slots;  // one per triangle, in input order
  size_t cells = 0;
  double triangle_texels = 0;                      // sum of the triangles' own areas in their cells (texels)
  double cell_texels = 0;                          // sum of the cells' (and patches') areas (texels)
  std::vector<std::pair<int, int>> patch_origins;  // top-left texel of each patch (make_footprint_layout)

  // Corners (v0 at the right angle, v1, v2) of triangle t in atlas coordinates (texel (i, j) covers [i, i+1]^2).
  std::array<Eigen::Vector2d, 3> corners(size_t t) const;
  // triangle_texels / (width * height): the share of the atlas that triangles' own areas fill.
  double efficiency() const;
};

// Lays out one triangle per entry (legs > 0; use footprint_leg_class). A diamond gets the larger leg of its two.
// Returns false when a leg is not positive, a partner does not name its triangle back, the gutter is negative, or the
// atlas would exceed max_side texels per side.
// patch_sizes: rectangles (width, height texels) to place as well, e.g. image patches (footprint_atlas.h); their
// triangles are the caller's (not counted in triangle_texels).
bool make_footprint_layout(const std::vector<FootprintTriangle>& triangles, int gutter_px, int max_side,
                           FootprintLayout* out, const std::vector<std::pair<int, int>>& patch_sizes = {});

}  // namespace rgbdcast
