// build_atlas: the undistorted per-triangle texture atlas (kAtlas) and the dispatch to the baseline (kFrame).
#include <meshoptimizer.h>

#include <chrono>
#include <cmath>

#include "atlas/atlas.h"
#include "atlas/atlas_layout.h"
#include "atlas/footprint_atlas.h"
#include "atlas/frame_texture.h"
#include "atlas/texture_encode.h"
#include "atlas/triangle_homography.h"
#include "base/stopwatch.h"

namespace rgbdcast {

const char* to_string(TextureMode mode) {
  switch (mode) {
    case TextureMode::kAtlas:
      return "atlas";
    case TextureMode::kFrame:
      return "frame";
    case TextureMode::kAuto:
      return "auto";
    case TextureMode::kFootprint:
      return "footprint";
  }
  return "?";
}

Result<TextureMode> parse_texture_mode(const std::string& name) {
  if (name == "atlas") return TextureMode::kAtlas;
  if (name == "frame") return TextureMode::kFrame;
  if (name == "auto") return TextureMode::kAuto;
  if (name == "footprint") return TextureMode::kFootprint;
  return make_error(ErrorCode::kInvalidArgument,
                    "texture mode must be 'atlas', 'frame', 'auto' or 'footprint', got '" + name + "'");
}

namespace {

struct Slot {
  std::array<Eigen::Vector3d, 3> v;
  TriangleTextureMap map;
};

// Fills the texels of one cell that belong to `slot` (all of them when it has no partner).
void fill_slot(const CellLayout& layout, size_t slot, bool has_partner, const Slot& s, const cv::Mat& rgb,
               Image* atlas) {
  int x0, y0;
  bool lower;
  layout.cell_of(slot, &x0, &y0, &lower);
  const int S = layout.cell_px;
  const Eigen::Matrix3d& M_inv = s.map.image_from_atlas;
  // Fallback for texels whose continued plane passes behind the camera: the centroid's pixel.
  const Eigen::Vector3d c =
      s.map.H * Eigen::Vector3d((s.map.plane[0].x() + s.map.plane[1].x() + s.map.plane[2].x()) / 3,
                                (s.map.plane[0].y() + s.map.plane[1].y() + s.map.plane[2].y()) / 3, 1);
  for (int j = 0; j < S; ++j) {
    for (int i = 0; i < S; ++i) {
      if (layout.two_per_cell && (has_partner || lower)) {
        const bool upper_texel = i + j + 1 < S;  // centre sum (i + 0.5) + (j + 0.5) < S - 0.5
        if (upper_texel == lower) continue;
      }
      const Eigen::Vector3d h = M_inv * Eigen::Vector3d(x0 + i + 0.5, y0 + j + 0.5, 1.0);
      double u, v;
      if (h.z() > 1e-9 * std::abs(c.z())) {
        u = h.x() / h.z();
        v = h.y() / h.z();
      } else {
        u = c.x() / c.z();
        v = c.y() / c.z();
      }
      atlas_detail::sample_bilinear(rgb, u, v, atlas->pixel(x0 + i, y0 + j));
    }
  }
}

}  // namespace

Result<AtlasResult> build_atlas(const Mesh& mesh, const cv::Mat& color_rgb, const Intrinsics& pinhole,
                                const AtlasOptions& options) {
  if (auto st = atlas_detail::check_inputs(mesh, color_rgb, pinhole); !st) return st.error();
  if (options.jpeg_quality < 1 || options.jpeg_quality > 100)
    return make_error(ErrorCode::kInvalidArgument, "atlas: JPEG quality must be 1..100");
  if (options.mode == TextureMode::kAuto) {
    CellLayout layout;
    if (!make_cell_layout(mesh.triangle_count(), options.cell_size_px, options.gutter_px, options.two_per_cell,
                          options.max_atlas_side_px, &layout))
      return make_error(ErrorCode::kInvalidArgument, "atlas: cell size leaves no room for a triangle");
    const double own_texels = 0.5 * layout.leg_px() * layout.leg_px();
    AtlasOptions chosen = options;
    chosen.mode = atlas_detail::median_projected_area_px(mesh, pinhole.K()) > own_texels ? TextureMode::kAtlas
                                                                                         : TextureMode::kFrame;
    return build_atlas(mesh, color_rgb, pinhole, chosen);
  }
  if (options.mode == TextureMode::kFrame) return atlas_detail::build_frame_texture(mesh, color_rgb, pinhole, options);
  if (options.mode == TextureMode::kFootprint)
    return atlas_detail::build_footprint_atlas(mesh, color_rgb, pinhole, options);

  const auto t0 = std::chrono::steady_clock::now();
  const Eigen::Matrix3d K = pinhole.K();
  std::vector<std::uint32_t> order(mesh.indices);
  if (options.reorder_triangles.value_or(true))
    meshopt_optimizeVertexCache(order.data(), mesh.indices.data(), mesh.indices.size(), mesh.positions.size());

  // Triangles that can be textured, in output order.
  std::vector<std::array<std::uint32_t, 3>> tris;
  tris.reserve(order.size() / 3);
  AtlasResult r;
  r.mode = TextureMode::kAtlas;
  for (size_t t = 0; t + 2 < order.size(); t += 3) {
    const Eigen::Vector3d a = mesh.positions[order[t]].cast<double>(), b = mesh.positions[order[t + 1]].cast<double>(),
                          c = mesh.positions[order[t + 2]].cast<double>();
    TriangleTextureMap probe;
    const std::array<Eigen::Vector2d, 3> unit = {Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 0), Eigen::Vector2d(0, 1)};
    if (!triangle_texture_map(a, b, c, K, unit, &probe)) {
      ++r.dropped_triangles;
      continue;
    }
    tris.push_back({order[t], order[t + 1], order[t + 2]});
  }
  if (tris.empty()) return make_error(ErrorCode::kEmpty, "atlas: no triangle in front of the camera with an area");

  CellLayout layout;
  if (!make_cell_layout(tris.size(), options.cell_size_px, options.gutter_px, options.two_per_cell,
                        options.max_atlas_side_px, &layout))
    return make_error(ErrorCode::kInvalidArgument, "atlas: cell size " + std::to_string(options.cell_size_px) +
                                                       " with gutter " + std::to_string(options.gutter_px) +
                                                       " leaves no room for a triangle, or " +
                                                       std::to_string(tris.size()) + " triangles exceed a " +
                                                       std::to_string(options.max_atlas_side_px) + " texel atlas");

  Image atlas = Image::make(layout.width, layout.height, 3);
  Mesh& out = r.mesh;
  atlas_detail::reserve_cell_triangles(tris.size(), &out);
  const Eigen::Vector2d inv_size(1.0 / layout.width, 1.0 / layout.height);
  for (size_t k = 0; k < tris.size(); ++k) {
    Slot s;
    for (int i = 0; i < 3; ++i) s.v[i] = mesh.positions[tris[k][i]].cast<double>();
    const auto corners = layout.corners(k);
    if (!triangle_texture_map(s.v[0], s.v[1], s.v[2], K, corners, &s.map))
      return make_error(ErrorCode::kInternal, "atlas: triangle map failed after the probe succeeded");
    const bool has_partner = (k % 2 == 0) ? (k + 1 < tris.size()) : true;
    fill_slot(layout, k, has_partner, s, color_rgb, &atlas);
    atlas_detail::append_cell_triangle(mesh, tris[k], corners, inv_size, &out);
  }
  atlas_detail::set_atlas_texture(std::move(atlas), layout.cells, tris.size(), &r);
  r.median_source_px = atlas_detail::median_projected_area_px(mesh, K);
  r.texels_per_triangle = 0.5 * layout.leg_px() * layout.leg_px();
  r.ms = ms_since(t0);
  if (options.encode)
    if (auto st = attach_jpeg(out, options.jpeg_quality, &r.encode_ms); !st) return st.error();
  return r;
}

}  // namespace rgbdcast
