// The footprint atlas: per-triangle undistorted texture in cells sized to the triangle's image footprint.
#include "atlas/footprint_atlas.h"

#include <meshoptimizer.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <unordered_map>

#include "atlas/cell_fill.h"
#include "atlas/footprint_layout.h"
#include "atlas/frame_texture.h"
#include "atlas/texture_encode.h"
#include "atlas/triangle_homography.h"
#include "atlas/unsampled_fill.h"
#include "base/stopwatch.h"

namespace rgbdcast::atlas_detail {

namespace {

using Clock = std::chrono::steady_clock;

// Fills the texels of a cell that belong to one triangle from the colour image through the triangle's map
// (atlas/cell_fill.h). Texels whose continued plane passes behind the camera take the centroid's pixel.
void fill_cell_part(const FootprintSlot& slot, const TriangleTextureMap& map, const CellSource& src, Image* atlas,
                    std::uint8_t* sampled) {
  const Eigen::Vector3d c = map.H * Eigen::Vector3d((map.plane[0].x() + map.plane[1].x() + map.plane[2].x()) / 3,
                                                    (map.plane[0].y() + map.plane[1].y() + map.plane[2].y()) / 3, 1);
  fill_cell_triangle(slot, map.image_from_atlas, c, src, atlas, sampled);
}

// Cheap version of triangle_texture_map's rejection test (same thresholds): in front of the camera, with an area.
bool texturable(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  if (!(a.z() > 0.0 && b.z() > 0.0 && c.z() > 0.0)) return false;
  const Eigen::Vector3d d1 = b - a;
  return d1.squaredNorm() > 0.0 && 0.5 * d1.cross(c - a).norm() > 1e-12;
}

// How far (pixels) the frame texture's affine mapping of the triangle (UVs at the projected vertices, interpolated
// linearly in the 3D point's barycentric coordinates, as a renderer does) strays from the true projection: at the
// edge midpoints (|p_a - p_b| |z_a - z_b| / (2 (z_a + z_b)), exact for a midpoint) and at the centroid.
double affine_deviation_px(const std::array<Eigen::Vector3d, 3>& v, const std::array<Eigen::Vector2d, 3>& px,
                           const Eigen::Matrix3d& K) {
  double d = 0;
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3;
    d = std::max(d, 0.5 * (px[i] - px[j]).norm() * std::abs(v[i].z() - v[j].z()) / (v[i].z() + v[j].z()));
  }
  const Eigen::Vector3d c = K * ((v[0] + v[1] + v[2]) / 3);
  return std::max(d, ((px[0] + px[1] + px[2]) / 3 - c.head<2>() / c.z()).norm());
}

// Diamonds: pairs of triangles with the same hypotenuse (v1, v2 after the rotation) whose right angles project on
// opposite sides of it in the image (no fold). Pairs are found by sorting the hypotenuses, so the result is
// deterministic; an edge with more than two such triangles (non-manifold) gets no diamond.
void find_diamonds(const std::vector<std::array<std::uint32_t, 3>>& tris, const std::vector<Eigen::Vector2d>& right_px,
                   const Mesh& mesh, const Eigen::Matrix3d& K, std::vector<FootprintTriangle>* cells) {
  std::vector<std::pair<std::uint64_t, std::uint32_t>> edges(tris.size());
  for (size_t t = 0; t < tris.size(); ++t) {
    const std::uint64_t a = std::min(tris[t][1], tris[t][2]), b = std::max(tris[t][1], tris[t][2]);
    edges[t] = {a << 32 | b, static_cast<std::uint32_t>(t)};
  }
  std::sort(edges.begin(), edges.end());
  auto pixel = [&](std::uint32_t v) -> Eigen::Vector2d {
    const Eigen::Vector3d h = K * mesh.positions[v].cast<double>();
    return h.head<2>() / h.z();
  };
  for (size_t k = 0; k + 1 < edges.size();) {
    size_t n = 1;
    while (k + n < edges.size() && edges[k + n].first == edges[k].first) ++n;
    if (n == 2) {
      const std::uint32_t t = edges[k].second, u = edges[k + 1].second;  // t < u
      const Eigen::Vector2d p1 = pixel(tris[t][1]), d = pixel(tris[t][2]) - p1;
      auto side = [&](const Eigen::Vector2d& q) { return d.x() * (q - p1).y() - d.y() * (q - p1).x(); };
      if (side(right_px[t]) * side(right_px[u]) < 0) {
        (*cells)[t].diamond_partner = u;
        (*cells)[u].diamond_partner = t;
        (*cells)[u].swapped = tris[u][1] == tris[t][1];
      }
    }
    k += n;
  }
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
  if (options.reorder_triangles.value_or(false))
    meshopt_optimizeVertexCache(order.data(), mesh.indices.data(), mesh.indices.size(), mesh.positions.size());

  // Texturable triangles, each rotated (winding kept) so that v0 is the vertex with the largest image angle, which
  // goes to the cell's right-angle corner; and the leg class of its footprint. Those whose frame mapping is exact
  // enough go to patches instead (patch_tile >= 0).
  AtlasResult r;
  r.mode = TextureMode::kFootprint;
  const bool patches_on = options.footprint_patch_deviation_px > 0.0;
  const int T = std::max(8, options.footprint_patch_tile_px);
  const int tiles_x = (color_rgb.cols + T - 1) / T, tiles_y = (color_rgb.rows + T - 1) / T;
  std::vector<std::array<std::uint32_t, 3>> tris;
  std::vector<std::array<Eigen::Vector2d, 3>> tri_px;
  std::vector<int> patch_tile;  // per triangle: its tile, or -1 for a cell
  std::vector<FootprintTriangle> cells;
  tris.reserve(order.size() / 3);
  tri_px.reserve(order.size() / 3);
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
    tri_px.push_back({px[right], px[(right + 1) % 3], px[(right + 2) % 3]});
    int tile = -1;
    if (patches_on) {
      const Eigen::Vector2d lo = px[0].cwiseMin(px[1]).cwiseMin(px[2]), hi = px[0].cwiseMax(px[1]).cwiseMax(px[2]);
      const Eigen::Vector2d centre = (px[0] + px[1] + px[2]) / 3;
      const bool inside = lo.x() >= 0 && lo.y() >= 0 && hi.x() <= color_rgb.cols - 1 && hi.y() <= color_rgb.rows - 1;
      if (inside && (hi - lo).maxCoeff() <= T && affine_deviation_px(v, px, K) <= options.footprint_patch_deviation_px)
        tile = static_cast<int>(centre.y()) / T * tiles_x + static_cast<int>(centre.x()) / T;
    }
    patch_tile.push_back(tile);
    if (tile < 0) cells.push_back({footprint_leg_class(options.texels_per_px * leg_px), -1, false});
  }
  if (tris.empty())
    return make_error(ErrorCode::kEmpty, "footprint atlas: no triangle in front of the camera with an area");

  // Cell triangles (and their pixels) in order, for the diamonds; patches: each tile's pixel rectangle.
  std::vector<std::array<std::uint32_t, 3>> cell_tris;
  std::vector<Eigen::Vector2d> cell_right_px;
  std::vector<int> cell_of(tris.size(), -1);
  struct Rect {
    int x0 = 1 << 30, y0 = 1 << 30, x1 = -1, y1 = -1;
  };
  std::vector<Rect> tile_rect(patches_on ? static_cast<size_t>(tiles_x) * tiles_y : 0);
  for (size_t k = 0; k < tris.size(); ++k) {
    if (patch_tile[k] < 0) {
      cell_of[k] = static_cast<int>(cell_tris.size());
      cell_tris.push_back(tris[k]);
      cell_right_px.push_back(tri_px[k][0]);
      continue;
    }
    Rect& rc = tile_rect[patch_tile[k]];
    for (const auto& p : tri_px[k]) {  // a bilinear lookup at p reads pixels floor(p) and floor(p) + 1
      rc.x0 = std::min(rc.x0, static_cast<int>(std::floor(p.x())));
      rc.y0 = std::min(rc.y0, static_cast<int>(std::floor(p.y())));
      rc.x1 = std::max(rc.x1, std::min(color_rgb.cols - 1, static_cast<int>(std::ceil(p.x()))));
      rc.y1 = std::max(rc.y1, std::min(color_rgb.rows - 1, static_cast<int>(std::ceil(p.y()))));
    }
  }
  std::vector<int> patch_of_tile(tile_rect.size(), -1);
  std::vector<std::pair<int, int>> patch_sizes;
  std::vector<Rect> patch_rect;
  for (size_t t = 0; t < tile_rect.size(); ++t)
    if (tile_rect[t].x1 >= 0) {
      patch_of_tile[t] = static_cast<int>(patch_sizes.size());
      patch_sizes.emplace_back(tile_rect[t].x1 - tile_rect[t].x0 + 1, tile_rect[t].y1 - tile_rect[t].y0 + 1);
      patch_rect.push_back(tile_rect[t]);
    }
  if (options.footprint_diamonds) find_diamonds(cell_tris, cell_right_px, mesh, K, &cells);

  FootprintLayout layout;
  if (!make_footprint_layout(cells, options.gutter_px, options.max_atlas_side_px, &layout, patch_sizes))
    return make_error(ErrorCode::kInvalidArgument, "footprint atlas: " + std::to_string(tris.size()) +
                                                       " triangles at " + std::to_string(options.texels_per_px) +
                                                       " texels per pixel exceed a " +
                                                       std::to_string(options.max_atlas_side_px) + " texel atlas");

  const CellSource src{color_rgb.ptr<std::uint8_t>(0), color_rgb.step[0], color_rgb.cols, color_rgb.rows};
  Image atlas = Image::make(layout.width, layout.height, 3);
  std::vector<std::uint8_t> sampled(static_cast<size_t>(layout.width) * layout.height, 0);
  for (size_t p = 0; p < patch_rect.size(); ++p) {  // patches: the frame's pixels, 1:1
    const Rect& rc = patch_rect[p];
    const auto [ax, ay] = layout.patch_origins[p];
    for (int y = rc.y0; y <= rc.y1; ++y)
      std::copy_n(color_rgb.ptr<std::uint8_t>(y) + 3 * rc.x0, 3 * (rc.x1 - rc.x0 + 1), atlas.pixel(ax, ay + y - rc.y0));
  }
  Mesh& out = r.mesh;
  reserve_cell_triangles(tris.size(), &out);
  const Eigen::Vector2d inv_size(1.0 / layout.width, 1.0 / layout.height);
  std::unordered_map<std::uint64_t, std::uint32_t> patch_vertex;  // (mesh vertex, patch) -> output vertex
  patch_vertex.reserve(r.patch_triangles + tris.size() - cell_tris.size());
  for (size_t k = 0; k < tris.size(); ++k) {
    if (cell_of[k] < 0) {
      const int p = patch_of_tile[patch_tile[k]];
      const Eigen::Vector2d shift = Eigen::Vector2d(layout.patch_origins[p].first - patch_rect[p].x0 + 0.5,
                                                    layout.patch_origins[p].second - patch_rect[p].y0 + 0.5);
      std::array<Eigen::Vector2d, 3> q;
      for (int i = 0; i < 3; ++i) q[i] = tri_px[k][i] + shift;
      mark_sampled_texels(q[0], q[1], q[2], layout.width, layout.height, sampled.data());
      // Within a patch a vertex has one UV (its projection, shifted), so the patch's triangles share their vertices.
      for (int i = 0; i < 3; ++i) {
        const std::uint64_t key = std::uint64_t(tris[k][i]) << 32 | std::uint32_t(p);
        auto [it, added] = patch_vertex.try_emplace(key, static_cast<std::uint32_t>(out.positions.size()));
        if (added) {
          out.positions.push_back(mesh.positions[tris[k][i]]);
          out.uvs.push_back(q[i].cwiseProduct(inv_size).cast<float>());
        }
        out.indices.push_back(it->second);
      }
      layout.triangle_texels +=
          0.5 * std::abs((q[1] - q[0]).x() * (q[2] - q[0]).y() - (q[1] - q[0]).y() * (q[2] - q[0]).x());
      ++r.patch_triangles;
      continue;
    }
    const size_t c = static_cast<size_t>(cell_of[k]);
    const auto corners = layout.corners(c);
    TriangleTextureMap map;
    if (!triangle_texture_map(mesh.positions[tris[k][0]].cast<double>(), mesh.positions[tris[k][1]].cast<double>(),
                              mesh.positions[tris[k][2]].cast<double>(), K, corners, &map))
      return make_error(ErrorCode::kInternal, "footprint atlas: triangle map failed on a texturable triangle");
    fill_cell_part(layout.slots[c], map, src, &atlas, sampled.data());
    append_cell_triangle(mesh, tris[k], corners, inv_size, &out);
  }
  r.patches = patch_rect.size();
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
  if (options.encode)
    if (auto st = attach_jpeg(out, options.jpeg_quality, &r.encode_ms); !st) return st.error();
  return r;
}

}  // namespace rgbdcast::atlas_detail
