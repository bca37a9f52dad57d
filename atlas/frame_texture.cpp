#include "atlas/frame_texture.h"

#include <meshoptimizer.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "atlas/texture_encode.h"
#include "atlas/triangle_homography.h"
#include "atlas/unsampled_fill.h"
#include "base/stopwatch.h"

namespace rgbdcast::atlas_detail {

Status check_inputs(const Mesh& mesh, const cv::Mat& color_rgb, const Intrinsics& k) {
  if (color_rgb.empty() || color_rgb.type() != CV_8UC3)
    return make_error(ErrorCode::kInvalidArgument, "atlas: colour image must be a non-empty 8-bit RGB image");
  if (!(std::isfinite(k.fx) && std::isfinite(k.fy) && std::isfinite(k.cx) && std::isfinite(k.cy) && k.fx > 0 &&
        k.fy > 0))
    return make_error(ErrorCode::kInvalidArgument, "atlas: intrinsics must be finite with fx, fy > 0");
  if (k.width != color_rgb.cols || k.height != color_rgb.rows)
    return make_error(ErrorCode::kInvalidArgument, "atlas: intrinsics are for " + std::to_string(k.width) + "x" +
                                                       std::to_string(k.height) + " but the colour image is " +
                                                       std::to_string(color_rgb.cols) + "x" +
                                                       std::to_string(color_rgb.rows));
  if (mesh.indices.size() % 3 != 0)
    return make_error(ErrorCode::kInvalidArgument, "atlas: index count is not a multiple of 3");
  if (mesh.indices.empty()) return make_error(ErrorCode::kEmpty, "atlas: the mesh has no triangles");
  for (std::uint32_t i : mesh.indices)
    if (i >= mesh.positions.size())
      return make_error(ErrorCode::kInvalidArgument, "atlas: index " + std::to_string(i) + " out of range");
  for (const auto& p : mesh.positions)
    if (!p.allFinite()) return make_error(ErrorCode::kInvalidArgument, "atlas: a vertex position is not finite");
  return ok_status();
}

void sample_bilinear(const cv::Mat& rgb, double u, double v, std::uint8_t out[3]) {
  const double maxu = rgb.cols - 1, maxv = rgb.rows - 1;
  if (!std::isfinite(u)) u = 0;
  if (!std::isfinite(v)) v = 0;
  u = std::clamp(u, 0.0, maxu);
  v = std::clamp(v, 0.0, maxv);
  const int x0 = static_cast<int>(u), y0 = static_cast<int>(v);
  const int x1 = std::min(x0 + 1, rgb.cols - 1), y1 = std::min(y0 + 1, rgb.rows - 1);
  const double fx = u - x0, fy = v - y0;
  const std::uint8_t* r0 = rgb.ptr<std::uint8_t>(y0);
  const std::uint8_t* r1 = rgb.ptr<std::uint8_t>(y1);
  for (int c = 0; c < 3; ++c) {
    const double top = r0[3 * x0 + c] * (1 - fx) + r0[3 * x1 + c] * fx;
    const double bot = r1[3 * x0 + c] * (1 - fx) + r1[3 * x1 + c] * fx;
    out[c] = static_cast<std::uint8_t>(std::lround(top * (1 - fy) + bot * fy));
  }
}

double median_projected_area_px(const Mesh& mesh, const Eigen::Matrix3d& K) {
  std::vector<double> areas;
  areas.reserve(mesh.triangle_count());
  for (size_t t = 0; t < mesh.triangle_count(); ++t)
    areas.push_back(projected_area_px(mesh.positions[mesh.indices[3 * t]].cast<double>(),
                                      mesh.positions[mesh.indices[3 * t + 1]].cast<double>(),
                                      mesh.positions[mesh.indices[3 * t + 2]].cast<double>(), K));
  if (areas.empty()) return 0.0;
  std::nth_element(areas.begin(), areas.begin() + areas.size() / 2, areas.end());
  return areas[areas.size() / 2];
}

void reserve_cell_triangles(size_t triangles, Mesh* out) {
  out->positions.reserve(triangles * 3);
  out->uvs.reserve(triangles * 3);
  out->indices.reserve(triangles * 3);
}

void set_atlas_texture(Image texture, size_t cells, size_t triangles, AtlasResult* r) {
  r->width = texture.width;
  r->height = texture.height;
  r->texels = static_cast<size_t>(texture.width) * texture.height;
  r->cells = cells;
  r->triangles = triangles;
  r->mesh.texture = std::move(texture);
}

void append_cell_triangle(const Mesh& mesh, const std::array<std::uint32_t, 3>& tri,
                          const std::array<Eigen::Vector2d, 3>& corners, const Eigen::Vector2d& inv_size, Mesh* out) {
  for (int i = 0; i < 3; ++i) {
    out->indices.push_back(static_cast<std::uint32_t>(out->positions.size()));
    out->positions.push_back(mesh.positions[tri[i]]);
    out->uvs.push_back(corners[i].cwiseProduct(inv_size).cast<float>());
  }
}

Result<AtlasResult> build_frame_texture(const Mesh& mesh, const cv::Mat& color_rgb, const Intrinsics& pinhole,
                                        const AtlasOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  AtlasResult r;
  r.mode = TextureMode::kFrame;
  Mesh& out = r.mesh;
  out.positions = mesh.positions;
  out.uvs.resize(mesh.positions.size(), Eigen::Vector2f::Zero());
  const double W = color_rgb.cols, H = color_rgb.rows;
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const Eigen::Vector3d p = mesh.positions[i].cast<double>();
    if (p.z() <= 0.0) continue;
    const Eigen::Vector2d px = pinhole.project(p);
    // Pixel centre (u, v) sits at texture coordinate ((u + 0.5) / W, (v + 0.5) / H), origin at the top-left corner.
    out.uvs[i] = Eigen::Vector2f(static_cast<float>((px.x() + 0.5) / W), static_cast<float>((px.y() + 0.5) / H));
  }
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    const std::uint32_t a = mesh.indices[3 * t], b = mesh.indices[3 * t + 1], c = mesh.indices[3 * t + 2];
    if (mesh.positions[a].z() <= 0 || mesh.positions[b].z() <= 0 || mesh.positions[c].z() <= 0 || a == b || b == c ||
        a == c) {
      ++r.dropped_triangles;
      continue;
    }
    out.indices.insert(out.indices.end(), {a, b, c});
  }
  if (out.indices.empty()) return make_error(ErrorCode::kEmpty, "frame texture: no triangle in front of the camera");
  if (options.reorder_triangles.value_or(true)) {
    // Vertex-cache order for the triangles, then vertices in first-use order (unused ones dropped): neighbours end up
    // next to each other in every stream, which is what meshopt's delta codecs want.
    std::vector<std::uint32_t> tri(out.indices.size());
    meshopt_optimizeVertexCache(tri.data(), out.indices.data(), out.indices.size(), out.positions.size());
    std::vector<std::uint32_t> remap(out.positions.size());
    const size_t used = meshopt_optimizeVertexFetchRemap(remap.data(), tri.data(), tri.size(), out.positions.size());
    std::vector<Eigen::Vector3f> pos(used);
    std::vector<Eigen::Vector2f> uvs(used);
    for (size_t i = 0; i < remap.size(); ++i)
      if (remap[i] != ~0u) pos[remap[i]] = out.positions[i], uvs[remap[i]] = out.uvs[i];
    for (auto& i : tri) i = remap[i];
    out.positions = std::move(pos);
    out.uvs = std::move(uvs);
    out.indices = std::move(tri);
  }
  out.texture = image_from_rgb_mat(color_rgb);
  if (options.fill_unsampled.value_or(false)) {
    const auto f0 = std::chrono::steady_clock::now();
    auto sampled = texels_sampled_by_uvs(out, out.texture.width, out.texture.height);
    if (!sampled) return sampled.error();
    r.unsampled_texels = static_cast<size_t>(std::count(sampled->begin(), sampled->end(), 0));
    if (auto st = fill_unsampled_texels(&out.texture, *sampled); !st) return st.error();
    r.fill_ms = ms_since(f0);
  }
  r.width = color_rgb.cols;
  r.height = color_rgb.rows;
  r.texels = static_cast<size_t>(r.width) * r.height;
  r.triangles = out.triangle_count();
  r.median_source_px = median_projected_area_px(mesh, pinhole.K());
  r.texels_per_triangle = r.median_source_px;
  r.ms = ms_since(t0);
  if (options.encode)
    if (auto st = attach_jpeg(out, options.jpeg_quality, &r.encode_ms); !st) return st.error();
  return r;
}

}  // namespace rgbdcast::atlas_detail
