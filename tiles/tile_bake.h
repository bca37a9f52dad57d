#pragma once
// Baking a tile's texture, for leaves and inner tiles alike: every triangle gets its own cell of one footprint atlas
// (atlas/footprint_layout.h), the layout's legs are halved until the atlas fits, the caller fills each triangle's
// cell, the texels no cell samples are filled smoothly (atlas/unsampled_fill.h) and the atlas is JPEG-encoded.
#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include <Eigen/Core>

#include "atlas/footprint_layout.h"
#include "scene/mesh.h"
#include "scene/result.h"
#include "tiles/tile_content.h"

namespace rgbdcast::tiles {

struct BakeTriangle {
  std::array<Eigen::Vector3d, 3> world;  // corners in metres, the one at the cell's right angle first
  int leg = 1;                           // texels along each leg (footprint_leg_class)
};

// Fills triangle i's texels of its cell `slot` (atlas/cell_fill.h), where `corners` are the atlas positions (texel
// units) of world[0], world[1], world[2], and marks them in `sampled` (atlas width x height).
using CellFill = std::function<void(size_t i, const FootprintSlot& slot, const std::array<Eigen::Vector2d, 3>& corners,
                                    Image* atlas, std::uint8_t* sampled)>;

// The textured mesh of `tris`: each triangle its own three vertices (world positions as floats, UVs at its cell's
// corners), in input order; texture RGB8 and its JPEG (options.jpeg_quality). kEmpty for no triangle;
// kInvalidArgument when the triangles do not fit options.max_atlas_side_px even with the smallest legs.
Result<Mesh> bake_atlas_mesh(const std::vector<BakeTriangle>& tris, const BakeOptions& options, const CellFill& fill);

}  // namespace rgbdcast::tiles
