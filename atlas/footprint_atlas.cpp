// The footprint atlas: per-triangle undistorted texture in cells sized to the triangle's image footprint.
#include "atlas/footprint_atlas.h"

#include <meshoptimizer.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>

#include "atlas/footprint_layout.h"
#include "atlas/frame_texture.h"
#include "atlas/texture_encode.h"
#include "atlas/triangle_homography.h"
#include "atlas/unsampled_fill.h"

namespace rgbdcast::atlas_detail {

namespace {

using Clock = std::chrono::steady_clock;
double ms_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

// Bilinear RGB lookup at pixel (u, v) (centres at integers), clamped to the image.
inline void sample_rgb(const cv::Mat& rgb, double u, double v, std::uint8_t* out) {
  u = std::clamp(u, 0.0, rgb.cols - 1.0);
  v = std::clamp(v, 0.0, rgb.rows - 1.0);
  const int x0 = static_cast<int>(u), y0 = static_cast<int>(v);
  const int dx = x0 + 1 < rgb.cols ? 3 : 0;
  const size_t dy = y0 + 1 < rgb.rows ? rgb.step[0] : 0;
  const float fx = static_cast<float>(u - x0), fy = static_cast<float>(v - y0);
  const std::uint8_t* p = rgb.ptr<std::uint8_t>(y0) + 3 * x0;
  for (int c = 0; c < 3; ++c) {
    const float top = p[c] + fx * (p[c + dx] - p[c]);
    const float bot = p[c + dy] + fx * (p[c + dy + dx] - p[c + dy]);
    out[c] = static_cast<std::uint8_t>(top + fy * (bot - top) + 0.5f);
  }
}

// Fills the texels of a cell that belong to one triangle (the upper part i + j + 1 < S, or the rest for the lower
// triangle) from the colour image through M^-1, and marks them sampled. Texels whose continued plane passes behind
// the camera take the centroid's pixel.
void fill_cell_part(const FootprintSlot& slot, const TriangleTextureMap& map, const cv::Mat& rgb, Image* atlas,
                    std::uint8_t* sampled) {
  const int S = slot.cell_px;
  const Eigen::Matrix3d& M = map.image_from_atlas;
  const Eigen::Vector3d c = map.H * Eigen::Vector3d((map.plane[0].x() + map.plane[1].x() + map.plane[2].x()) / 3,
                                                    (map.plane[0].y() + map.plane[1].y() + map.plane[2].y()) / 3, 1);
  const double cu = c.x() / c.z(), cv = c.y() / c.z(), min_w = 1e-9 * std::abs(c.z());
  const Eigen::Vector3d step = M.col(0);
  for (int j = 0; j < S; ++j) {
    const int split = S - 1 - j;  // texels i < split are the upper triangle's
    const int i0 = slot.lower ? split : 0, i1 = slot.lower ? S : split;
    Eigen::Vector3d h = M * Eigen::Vector3d(slot.x0 + i0 + 0.5, slot.y0 + j + 0.5, 1.0);
    std::uint8_t* px = atlas->pixel(slot.x0 + i0, slot.y0 + j);
    std::uint8_t* mk = sampled + static_cast<size_t>(slot.y0 + j) * atlas->width + slot.x0 + i0;
    for (int i = i0; i < i1; ++i, h += step, px += 3, ++mk) {
      if (h.z() > min_w) {
        const double inv = 1.0 / h.z();
        sample_rgb(rgb, h.x() * inv, h.y() * inv, px);
      } else {
        sample_rgb(rgb, cu, cv, px);
      }
      *mk = 1;
    }
  }
}

// Cheap version of triangle_texture_map's rejection test (same thresholds): in front of the camera, with an area.
bool texturable(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  if (!(a.z() > 0.0 && b.z() > 0.0 && c.z() > 0.0)) return false;
  const Eigen::Vector3d d1 = b - a;
  return d1.squaredNorm() > 0.0 && 0.5 * d1.cross(c - a).norm() > 1e-12;
}

}  // namespace

Result<AtlasResult> build_footprint_atlas(const Mesh& mesh, const cv::Mat& color_rgb, const Intrinsics& pinhole,
                                          const AtlasOptions& options) {
  if (!(options.texels_per_px > 0.0 && options.texels_per_px <= 16.0))
    return make_error(ErrorCode::kInvalidArgument, "footprint atlas: texels_per_px must be in (0, 16]");
  if (options.gutter_px < 1 || options.gutter_px > 16)
    return make_error(ErrorCode::kInvalidArgument, "footprint atlas: gutter must be 1..16 texels");
  const auto t0 = Clock::now();
  const Eigen::Matrix3d K = pinhole.K();
  std::vector<std::uint32_t> order(mesh.indices);
  if (options.reorder_triangles)
    meshopt_optimizeVertexCache(order.data(), mesh.indices.data(), mesh.indices.size(), mesh.positions.size());

  // Texturable triangles, each rotated (winding kept) so that v0 is the vertex with the largest image angle, which
  // goes to the cell's right-angle corner; and the leg class of its footprint.
  AtlasResult r;
  r.mode = TextureMode::kFootprint;
  std::vector<std::array<std::uint32_t, 3>> tris;
  std::vector<int> legs;
  tris.reserve(order.size() / 3);
  legs.reserve(order.size() / 3);
  for (size_t t = 0; t + 2 < order.size(); t += 3) {
    std::array<Eigen::Vector3d, 3> v;
    for (int i = 0; i < 3; ++i) v[i] = mesh.positions[order[t + i]].cast<double>();
    if (!texturable(v[0], v[1], v[2])) {
      ++r.dropped_triangles;
      continue;
    }
    std::array<Eigen::Vector2d, 3> px;
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d h = K * v[i];
      px[i] = h.head<2>() / h.z();
    }
    int right = 0;
    const double leg_px = footprint_leg_px(px, &right);
    tris.push_back({order[t + right], order[t + (right + 1) % 3], order[t + (right + 2) % 3]});
    legs.push_back(footprint_leg_class(options.texels_per_px * leg_px));
  }
  if (tris.empty()) return make_error(ErrorCode::kEmpty, "footprint atlas: no triangle in front of the camera with an area");

  FootprintLayout layout;
  if (!make_footprint_layout(legs, options.gutter_px, options.max_atlas_side_px, &layout))
    return make_error(ErrorCode::kInvalidArgument,
                      "footprint atlas: " + std::to_string(tris.size()) + " triangles at " +
                          std::to_string(options.texels_per_px) + " texels per pixel exceed a " +
                          std::to_string(options.max_atlas_side_px) + " texel atlas");

  Image atlas = Image::make(layout.width, layout.height, 3);
  std::vector<std::uint8_t> sampled(static_cast<size_t>(layout.width) * layout.height, 0);
  Mesh& out = r.mesh;
  reserve_cell_triangles(tris.size(), &out);
  const Eigen::Vector2d inv_size(1.0 / layout.width, 1.0 / layout.height);
  for (size_t k = 0; k < tris.size(); ++k) {
    const auto corners = layout.corners(k);
    TriangleTextureMap map;
    if (!triangle_texture_map(mesh.positions[tris[k][0]].cast<double>(), mesh.positions[tris[k][1]].cast<double>(),
                              mesh.positions[tris[k][2]].cast<double>(), K, corners, &map))
      return make_error(ErrorCode::kInternal, "footprint atlas: triangle map failed on a texturable triangle");
    fill_cell_part(layout.slots[k], map, color_rgb, &atlas, sampled.data());
    append_cell_triangle(mesh, tris[k], corners, inv_size, &out);
  }
  if (options.fill_unsampled.value_or(true)) {
    const auto f0 = Clock::now();
    r.unsampled_texels = static_cast<size_t>(std::count(sampled.begin(), sampled.end(), 0));
    if (auto st = fill_unsampled_texels(&atlas, sampled); !st) return st.error();
    r.fill_ms = ms_between(f0, Clock::now());
  }
  set_atlas_texture(std::move(atlas), layout.cells, tris.size(), &r);
  r.packing_efficiency = layout.efficiency();
  r.texels_per_triangle = layout.triangle_texels / static_cast<double>(tris.size());
  r.ms = ms_between(t0, Clock::now());
  r.median_source_px = median_projected_area_px(mesh, K);  // a diagnostic, not part of the texture's cost
  if (auto st = attach_jpeg(out, options.jpeg_quality, &r.encode_ms); !st) return st.error();
  return r;
}

}  // namespace rgbdcast::atlas_detail
