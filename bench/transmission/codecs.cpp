#include "bench/transmission/codecs.h"

#include <chrono>
#include <cmath>
#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "base/stopwatch.h"
#include "bench/transmission/draco_codec.h"
#include "gltf/gltf_io.h"
#include "pipeline/frame_defaults.h"
#include "pipeline/frame_scene.h"
#include "reduction/pipeline.h"

namespace rgbdcast::bench {

namespace {

Scene scene_at_capture(const Intrinsics& k) {
  Scene scene;
  CaptureCamera cam;
  cam.intrinsics = k;
  scene.cameras.push_back(cam);
  return scene;
}

Scene points_scene(PointCloud cloud, const Intrinsics& k) {
  Scene scene = scene_at_capture(k);
  SceneNode node;
  node.name = "cloud";
  node.points = std::move(cloud);
  scene.nodes.push_back(std::move(node));
  return scene;
}

void put_u32(Bytes& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}

std::uint32_t get_u32(const std::uint8_t* p) {
  return p[0] | (p[1] << 8) | (p[2] << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
}

// The two images of a JPEG + PNG payload, decoded: colour RGB CV_8UC3, depth CV_16UC1.
struct DecodedImages {
  cv::Mat color_rgb, depth_raw;
};

Result<DecodedImages> decode_images(const Bytes& bytes, const Intrinsics& k) {
  if (bytes.size() < 4) return make_error(ErrorCode::kInvalidInput, "jpeg+png payload too short");
  const std::uint32_t jpeg_size = get_u32(bytes.data());
  if (jpeg_size > bytes.size() - 4) return make_error(ErrorCode::kInvalidInput, "jpeg+png payload truncated");
  const cv::Mat jpeg(1, static_cast<int>(jpeg_size), CV_8U, const_cast<std::uint8_t*>(bytes.data() + 4));
  const cv::Mat png(1, static_cast<int>(bytes.size() - 4 - jpeg_size), CV_8U,
                    const_cast<std::uint8_t*>(bytes.data() + 4 + jpeg_size));
  DecodedImages out;
  cv::Mat bgr = cv::imdecode(jpeg, cv::IMREAD_COLOR);
  out.depth_raw = cv::imdecode(png, cv::IMREAD_UNCHANGED);
  // Lossy depth (encode_jpeg_png's depth_step > 1): back to full size, nearest neighbour (depth must not blend).
  if (!bgr.empty() && out.depth_raw.type() == CV_16UC1 && out.depth_raw.size() != bgr.size() &&
      out.depth_raw.cols > 0 && bgr.cols % out.depth_raw.cols == 0)
    cv::resize(out.depth_raw, out.depth_raw, bgr.size(), 0, 0, cv::INTER_NEAREST);
  if (bgr.empty() || out.depth_raw.type() != CV_16UC1 || bgr.size() != out.depth_raw.size() || bgr.cols != k.width ||
      bgr.rows != k.height)
    return make_error(ErrorCode::kInvalidInput, "jpeg+png payload: images do not decode to the camera's size");
  cv::cvtColor(bgr, out.color_rgb, cv::COLOR_BGR2RGB);
  return out;
}

Eigen::Vector3f backproject(const Intrinsics& k, int u, int v, double z) {
  return k.backproject(u, v, z).cast<float>();
}

Rgb8 rgb_at(const cv::Mat& color_rgb, int u, int v) {
  const cv::Vec3b c = color_rgb.at<cv::Vec3b>(v, u);
  return {c[0], c[1], c[2]};
}

}  // namespace

Bytes encode_raw_cloud(const RgbdFrame& frame) {
  const PointCloud cloud = full_cloud(frame);
  Bytes out;
  out.reserve(4 + cloud.size() * 15);
  put_u32(out, static_cast<std::uint32_t>(cloud.size()));
  for (size_t i = 0; i < cloud.size(); ++i) {
    const size_t at = out.size();
    out.resize(at + 15);
    std::memcpy(out.data() + at, cloud.positions[i].data(), 12);
    std::memcpy(out.data() + at + 12, cloud.colors[i].data(), 3);
  }
  return out;
}

Result<Scene> decode_raw_cloud(const Bytes& bytes, const Intrinsics& k) {
  if (bytes.size() < 4) return make_error(ErrorCode::kInvalidInput, "raw cloud too short");
  const size_t n = get_u32(bytes.data());
  if (bytes.size() != 4 + n * 15) return make_error(ErrorCode::kInvalidInput, "raw cloud size mismatch");
  PointCloud cloud;
  cloud.positions.resize(n);
  cloud.colors.resize(n);
  for (size_t i = 0; i < n; ++i) {
    std::memcpy(cloud.positions[i].data(), bytes.data() + 4 + 15 * i, 12);
    std::memcpy(cloud.colors[i].data(), bytes.data() + 4 + 15 * i + 12, 3);
  }
  return points_scene(std::move(cloud), k);
}

Result<Bytes> encode_jpeg_png(const RgbdFrame& frame, int jpeg_quality, int depth_step) {
  auto images = encode_jpeg_png16(frame, jpeg_quality, depth_step);  // pipeline/frame_defaults.h
  if (!images) return images.error();
  Bytes out;
  out.reserve(4 + images->bytes());
  put_u32(out, static_cast<std::uint32_t>(images->jpeg.size()));
  out.insert(out.end(), images->jpeg.begin(), images->jpeg.end());
  out.insert(out.end(), images->png.begin(), images->png.end());
  return out;
}

Result<Scene> decode_jpeg_png_cloud(const Bytes& bytes, const Intrinsics& k) {
  auto images = decode_images(bytes, k);
  if (!images) return images.error();
  PointCloud cloud;
  for (int v = 0; v < k.height; ++v)
    for (int u = 0; u < k.width; ++u) {
      const std::uint16_t d = images->depth_raw.at<std::uint16_t>(v, u);
      if (d == 0) continue;
      cloud.positions.push_back(backproject(k, u, v, d / k.depth_scale));
      cloud.colors.push_back(rgb_at(images->color_rgb, u, v));
    }
  return points_scene(std::move(cloud), k);
}

Result<Scene> decode_jpeg_png_grid_mesh(const Bytes& bytes, const Intrinsics& k, double max_jump) {
  auto images = decode_images(bytes, k);
  if (!images) return images.error();
  const cv::Mat& depth = images->depth_raw;
  // One vertex per pixel with depth; -1 elsewhere.
  std::vector<int> vertex_of(static_cast<size_t>(k.width) * k.height, -1);
  Mesh mesh;
  for (int v = 0; v < k.height; ++v)
    for (int u = 0; u < k.width; ++u) {
      const std::uint16_t d = depth.at<std::uint16_t>(v, u);
      if (d == 0) continue;
      vertex_of[static_cast<size_t>(v) * k.width + u] = static_cast<int>(mesh.positions.size());
      mesh.positions.push_back(backproject(k, u, v, d / k.depth_scale));
      mesh.colors.push_back(rgb_at(images->color_rgb, u, v));
    }
  auto continuous = [&](int a, int b, int c) {
    if (a < 0 || b < 0 || c < 0) return false;
    const float za = mesh.positions[a].z(), zb = mesh.positions[b].z(), zc = mesh.positions[c].z();
    return std::max({za, zb, zc}) <= (1.0 + max_jump) * std::min({za, zb, zc});
  };
  auto add = [&](int a, int b, int c) {
    if (!continuous(a, b, c)) return;
    mesh.indices.insert(mesh.indices.end(), {std::uint32_t(a), std::uint32_t(b), std::uint32_t(c)});
  };
  for (int v = 0; v + 1 < k.height; ++v)
    for (int u = 0; u + 1 < k.width; ++u) {
      const size_t i = static_cast<size_t>(v) * k.width + u;
      const int tl = vertex_of[i], tr = vertex_of[i + 1], bl = vertex_of[i + k.width], br = vertex_of[i + k.width + 1];
      add(tl, bl, tr);  // counter-clockwise seen from the camera (y down)
      add(tr, bl, br);
    }
  Scene scene = scene_at_capture(k);
  SceneNode node;
  node.name = "grid_mesh";
  node.mesh = std::move(mesh);
  scene.nodes.push_back(std::move(node));
  return scene;
}

Result<Bytes> encode_draco(const RgbdFrame& frame, int position_bits) {
  const PointCloud cloud = full_cloud(frame);
  std::vector<float> positions(3 * cloud.size());
  std::vector<std::uint8_t> colors(3 * cloud.size());
  for (size_t i = 0; i < cloud.size(); ++i) {
    std::memcpy(positions.data() + 3 * i, cloud.positions[i].data(), 12);
    std::memcpy(colors.data() + 3 * i, cloud.colors[i].data(), 3);
  }
  std::string error;
  Bytes out = draco_encode_points(positions, colors, position_bits, &error);
  if (out.empty()) return make_error(ErrorCode::kInternal, error);
  return out;
}

Result<Scene> decode_draco(const Bytes& bytes, const Intrinsics& k) {
  std::vector<float> positions;
  std::vector<std::uint8_t> colors;
  std::string error;
  if (!draco_decode_points(bytes.data(), bytes.size(), &positions, &colors, &error))
    return make_error(ErrorCode::kInvalidInput, error);
  PointCloud cloud;
  cloud.positions.resize(positions.size() / 3);
  cloud.colors.resize(positions.size() / 3);
  for (size_t i = 0; i < cloud.size(); ++i) {
    std::memcpy(cloud.positions[i].data(), positions.data() + 3 * i, 12);
    std::memcpy(cloud.colors[i].data(), colors.data() + 3 * i, 3);
  }
  return points_scene(std::move(cloud), k);
}

Result<Bytes> encode_rgbdcast(const RgbdFrame& frame, TextureMode mode, RgbdcastStageMs* stage_ms,
                              const ReductionParams& params, double budget_kb) {
  FrameReductionOptions options;
  options.params = params;
  options.texture = mode;
  options.budget_kb = budget_kb;
  auto textured = reduce_and_texture(frame, options);
  if (!textured) return textured.error();
  double reduce_ms = 0, texture_ms = 0;
  for (const auto& s : textured->stages) (s.name == "atlas" || s.name == "budget" ? texture_ms : reduce_ms) += s.ms;
  const auto t0 = std::chrono::steady_clock::now();
  auto glb = encode_glb(frame_scene(std::move(*textured), ""), GlbWriteOptions{});
  if (!glb) return glb.error();
  if (stage_ms) *stage_ms = {reduce_ms, texture_ms, ms_since(t0)};
  return std::move(*glb);
}

Result<Scene> decode_rgbdcast(const Bytes& bytes) { return decode_glb(bytes.data(), bytes.size()); }

}  // namespace rgbdcast::bench
