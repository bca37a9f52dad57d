#include "tiles/tile_bake.h"

#include <algorithm>

#include "atlas/texture_encode.h"
#include "atlas/unsampled_fill.h"

namespace rgbdcast::tiles {
namespace {

// Lays the cells out, halving every leg until the atlas fits max_side.
Result<FootprintLayout> layout_cells(const std::vector<BakeTriangle>& tris, const BakeOptions& options) {
  std::vector<FootprintTriangle> cells(tris.size());
  for (size_t i = 0; i < tris.size(); ++i) cells[i].leg = tris[i].leg;
  for (int attempt = 0; attempt < 10; ++attempt) {
    FootprintLayout layout;
    if (make_footprint_layout(cells, options.gutter_px, options.max_atlas_side_px, &layout)) return layout;
    for (auto& c : cells) c.leg = footprint_leg_class(std::max(1, c.leg / 2));
  }
  return make_error(ErrorCode::kInvalidArgument, "tile atlas: " + std::to_string(tris.size()) +
                                                     " triangles do not fit a " +
                                                     std::to_string(options.max_atlas_side_px) + " px atlas");
}

}  // namespace

Result<Mesh> bake_atlas_mesh(const std::vector<BakeTriangle>& tris, const BakeOptions& options, const CellFill& fill) {
  if (tris.empty()) return make_error(ErrorCode::kEmpty, "tile atlas: no triangle");
  auto layout = layout_cells(tris, options);
  if (!layout) return layout.error();
  Image atlas = Image::make(layout->width, layout->height, 3);
  std::vector<std::uint8_t> sampled(static_cast<size_t>(atlas.width) * atlas.height, 0);
  Mesh out;
  out.positions.reserve(3 * tris.size());
  out.uvs.reserve(3 * tris.size());
  const Eigen::Vector2d inv_size(1.0 / atlas.width, 1.0 / atlas.height);
  for (size_t i = 0; i < tris.size(); ++i) {
    const auto corners = layout->corners(i);
    fill(i, layout->slots[i], corners, &atlas, sampled.data());
    for (int k = 0; k < 3; ++k) {
      out.positions.push_back(tris[i].world[k].cast<float>());
      out.uvs.push_back(corners[k].cwiseProduct(inv_size).cast<float>());
      out.indices.push_back(static_cast<std::uint32_t>(out.indices.size()));
    }
  }
  if (auto st = fill_unsampled_texels(&atlas, sampled); !st) return st.error();
  out.texture = std::move(atlas);
  double encode_ms = 0.0;
  if (auto st = attach_jpeg(out, options.jpeg_quality, &encode_ms); !st) return st.error();
  return out;
}

}  // namespace rgbdcast::tiles
