#include "pipeline/frame_scene.h"

#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "atlas/texture_encode.h"

namespace rgbdcast {

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// Bytes of a GLB kept for the caller's extras (stage lists, intrinsics, capture metadata) when meeting a budget.
constexpr double kExtrasReserveBytes = 1200;
constexpr int kMinQuality = 20, kMaxQuality = 92;
// Limits of what a budget may give up: the mesh's tolerance (sigma units) and the texture's resolution. A budget
// below what they allow is not met; the report says so ("over-budget").
constexpr double kMaxToleranceFactor = 32;
constexpr double kMinTextureScale = 0.5;
// Geometry bytes per triangle of the compact GLB before one is measured, by codec: the medians of the realtime
// preset's meshes on the shared frames are about 4.4 with meshopt and 2.6 with Draco (bench/geometry_codec_bench).
// Only the first guess depends on them.
double prior_bytes_per_triangle(const GlbWriteOptions& o) {
  if (o.flavor != GlbFlavor::kCompact) return 24.0;  // float positions and UVs
  return o.geometry_codec == GeometryCodec::kDraco ? 2.6 : 4.4;
}

TextureMode resolve_texture(const FrameReductionOptions& o) {
  if (o.texture != TextureMode::kAuto) return o.texture;
  return o.params.preset == Preset::kRealtime ? TextureMode::kFrame : TextureMode::kAuto;
}

Scene node_scene(const SceneNode& node, const CaptureCamera& camera) {
  Scene s;
  s.nodes.push_back(node);
  s.cameras.push_back(camera);
  return s;
}

// The texture at a resolution scale (INTER_AREA: an integer factor such as 0.5 takes OpenCV's fast path). The
// mesh's UVs are relative, so a scaled texture needs no change to them.
Image scaled_texture(const Image& full, double scale) {
  if (scale >= 1.0) return full;
  const cv::Mat src(full.height, full.width, CV_8UC3, const_cast<std::uint8_t*>(full.data.data()));
  cv::Mat small;
  cv::resize(src, small, cv::Size(std::max(1, int(std::lround(full.width * scale))),
                                  std::max(1, int(std::lround(full.height * scale)))),
             0, 0, cv::INTER_AREA);
  return image_from_rgb_mat(small);
}

// Re-encodes the node's texture from `im` at a quality.
Status encode_texture(Mesh& mesh, const Image& im, int quality) {
  auto jpeg = encode_jpeg(im, quality);
  if (!jpeg) return jpeg.error();
  mesh.texture = im;
  mesh.texture_encoded = std::move(*jpeg);
  mesh.texture_mime = "image/jpeg";
  return ok_status();
}

}  // namespace

Status FrameReductionOptions::validate() const {
  if (auto st = params.validate(); !st) return st;
  if (atlas.jpeg_quality < 1 || atlas.jpeg_quality > 100)
    return make_error(ErrorCode::kInvalidArgument, "JPEG quality must be 1..100");
  if (!(std::isfinite(budget_kb) && budget_kb >= 0 && budget_kb <= 100000))
    return make_error(ErrorCode::kInvalidArgument, "budget must be 0 (none) or up to 100000 kB");
  if (budget_kb > 0 && budget_kb < 4)
    return make_error(ErrorCode::kInvalidArgument, "budget must be at least 4 kB (a GLB's headers and a texture)");
  if (!(std::isfinite(budget_geometry_share) && budget_geometry_share > 0 && budget_geometry_share < 1))
    return make_error(ErrorCode::kInvalidArgument, "the budget's geometry share must be between 0 and 1");
  if (budget_kb > 0 && params.preset != Preset::kRealtime)
    return make_error(ErrorCode::kInvalidArgument, "a byte budget needs the realtime preset (--preset realtime)");
  return ok_status();
}

Result<TexturedFrame> reduce_and_texture(const RgbdFrame& frame, const FrameReductionOptions& options,
                                         const Eigen::Matrix4d& camera_to_world,
                                         const std::vector<CoverageView>& earlier) {
  if (auto st = options.validate(); !st) return st.error();
  TexturedFrame out;
  out.preset = options.params.preset;
  out.camera.intrinsics = frame.intrinsics.pinhole();
  out.camera.camera_to_world = camera_to_world;
  out.camera.timestamp = frame.timestamp;
  out.camera.source = frame.color_path;
  out.camera.frame_index = frame.index;
  out.node.name = "keyframe_" + std::to_string(frame.index);
  out.node.to_world = camera_to_world;
  AtlasOptions atlas = options.atlas;
  atlas.mode = resolve_texture(options);
  // A budget starts from the best quality, so the texture is encoded once at it, not again.
  if (options.budget_kb > 0) atlas.jpeg_quality = kMaxQuality;
  // The realtime preset spends no texture bytes on pixels no triangle samples (they are filled smoothly).
  if (options.params.preset == Preset::kRealtime && !atlas.fill_unsampled) atlas.fill_unsampled = true;

  // Mesh at a tolerance -> covered triangles dropped -> textured. The realtime preset prepares its hierarchy once.
  Result<RealtimeReduction> prepared = make_error(ErrorCode::kInternal, "not prepared");
  if (options.params.preset == Preset::kRealtime) {
    prepared = prepare_realtime(frame, options.params);
    if (!prepared) return prepared.error();
  }
  auto texture_at = [&](double tolerance, std::vector<StageReport>* stages) -> Result<AtlasResult> {
    Result<ReducedFrame> reduced = prepared ? extract_realtime(*prepared, frame, tolerance)
                                            : reduce_frame(frame, options.params);
    if (!reduced) return reduced.error();
    *stages = reduced->stages;
    if (!earlier.empty()) {
      const auto t0 = Clock::now();
      drop_covered_triangles(reduced->mesh, camera_to_world, earlier);
      stages->push_back({"covered", "triangles", reduced->mesh.triangle_count(), ms_since(t0)});
      if (reduced->mesh.indices.empty())
        return make_error(ErrorCode::kEmpty, "every triangle is covered by earlier keyframes");
    }
    auto textured = build_atlas(reduced->mesh, frame.color_rgb, frame.intrinsics.pinhole(), atlas);
    if (!textured) return textured.error();
    stages->push_back({"atlas", "texels", textured->texels, textured->ms + textured->encode_ms});
    return textured;
  };

  const double tol0 = options.params.depth_mesh.tolerance_factor;
  if (options.budget_kb <= 0) {
    auto textured = texture_at(tol0, &out.stages);
    if (!textured) return textured.error();
    out.node.mesh = std::move(textured->mesh);
    out.atlas_stats = std::move(*textured);
    out.atlas_stats.mesh = Mesh{};
    return out;
  }

  // A budget (realtime preset, so the hierarchy is prepared). The mesh is extracted at a tolerance chosen from the
  // triangle count, which costs no encoding, and a bytes-per-triangle figure: first the codec's prior, then the one
  // just measured. So the frame is meshed, textured and encoded once or twice, not at every step of a search.
  const auto t0 = Clock::now();
  BudgetChoice& b = out.budget;
  b.budget_bytes = options.budget_kb * 1000.0;
  const double target = b.budget_bytes - kExtrasReserveBytes;
  const double geometry_cap = options.budget_geometry_share * target;
  const DepthMeshHierarchy& hierarchy = prepared->hierarchy;
  double bytes_per_triangle = prior_bytes_per_triangle(options.glb);
  double kept = 1.0;  // triangles left after dropping those earlier views cover, over those extracted
  Result<AtlasResult> textured = make_error(ErrorCode::kInternal, "not meshed");
  GlbStats st;
  auto measure = [&](const Mesh& mesh) -> Status {
    SceneNode probe;
    probe.mesh = mesh;
    probe.to_world = camera_to_world;
    auto glb = encode_glb(node_scene(probe, out.camera), options.glb, &st);
    ++b.encodes;
    if (!glb) return glb.error();
    b.geometry_bytes = st.geometry_bytes;
    b.texture_bytes = st.texture_bytes;
    b.glb_bytes = glb->size();
    return ok_status();
  };
  // The smallest tolerance >= tol0 whose mesh has at most `want` triangles, from the counts at every tolerance
  // (one walk of the hierarchy).
  const DepthMeshHierarchy::TriangleCounts counts = hierarchy.counts(tol0);
  auto tolerance_for = [&](double want) { return counts.smallest_with_at_most(want / kept, kMaxToleranceFactor); };
  auto remesh = [&](double tolerance) -> Status {
    std::vector<StageReport> stages;
    auto t = texture_at(tolerance, &stages);  // its texture at the best quality
    if (!t) return t.error();
    const double extracted = static_cast<double>(counts.at(tolerance));
    const double triangles = static_cast<double>(t->mesh.triangle_count());
    kept = extracted > 0 ? std::max(0.05, triangles / extracted) : 1.0;
    textured = std::move(t);
    out.stages = std::move(stages);
    b.tolerance_factor = tolerance;
    if (auto s = measure(textured->mesh); !s) return s;
    bytes_per_triangle = static_cast<double>(b.geometry_bytes) / std::max(1.0, triangles);
    return ok_status();
  };
  auto geometry_for = [&](double bytes) { return tolerance_for(bytes / bytes_per_triangle); };

  b.jpeg_quality = kMaxQuality;
  if (auto s = remesh(geometry_for(geometry_cap)); !s) return s.error();
  // One correction when the prior was off by more than 10 %.
  if (b.geometry_bytes > 1.1 * geometry_cap && b.tolerance_factor < kMaxToleranceFactor)
    if (auto s = remesh(geometry_for(geometry_cap)); !s) return s.error();
  b.rule = b.tolerance_factor > tol0 ? "geometry-capped" : "texture-fitted";
  if (b.glb_bytes <= target) {
    // The texture at its best quality leaves bytes over: they go back to the mesh (at most three times: the bytes a
    // triangle costs, and the share of triangles the collapses keep, change with the tolerance).
    for (int round = 0; round < 3; ++round) {
      const double left = target - static_cast<double>(b.glb_bytes);
      if (left <= 0.05 * target || b.tolerance_factor <= tol0) break;
      const double before = b.tolerance_factor;
      if (auto s = remesh(geometry_for(static_cast<double>(b.geometry_bytes) + 0.9 * left)); !s) return s.error();
      if (b.tolerance_factor == before) break;
    }
    if (b.tolerance_factor <= tol0 && b.glb_bytes <= target) b.rule = "fits";
  }
  // Texture: the largest quality (at full, then half resolution) whose bytes fit what is left. JPEG bytes are close
  // to exponential in the quality over 20..92, so the quality is interpolated on log bytes between two encodes and
  // refined once, instead of bisected.
  const double texture_target = target - static_cast<double>(b.glb_bytes - b.texture_bytes);
  if (static_cast<double>(b.texture_bytes) > texture_target) {
    const Image full_texture = textured->mesh.texture;
    Image half;
    auto source = [&](double scale) -> const Image& {
      if (scale >= 1.0) return full_texture;
      if (half.data.empty()) half = scaled_texture(full_texture, scale);
      return half;
    };
    int encoded_q = kMaxQuality;
    double encoded_scale = 1.0;
    auto bytes_at = [&](int q, double scale) -> Result<double> {
      if (auto s = encode_texture(textured->mesh, source(scale), q); !s) return s.error();
      encoded_q = q, encoded_scale = scale;
      ++b.encodes;
      return static_cast<double>(textured->mesh.texture_encoded.size());
    };
    double scale = 1.0;
    int q_hi = kMaxQuality;  // bytes at q_hi (at this scale) do not fit
    double bytes_hi = static_cast<double>(b.texture_bytes);
    int q_lo = kMinQuality;
    auto lo = bytes_at(q_lo, scale);
    if (!lo) return lo.error();
    if (*lo > texture_target) {  // the least quality does not fit at full resolution: half resolution
      scale = kMinTextureScale;
      lo = bytes_at(q_lo, scale);
      if (!lo) return lo.error();
      if (*lo <= texture_target) {
        auto hi = bytes_at(q_hi, scale);
        if (!hi) return hi.error();
        bytes_hi = *hi;
      }
    }
    double bytes_lo = *lo;
    if (bytes_lo <= texture_target && bytes_hi > texture_target) {
      for (int step = 0; step < 3 && q_hi - q_lo > 2; ++step) {
        const double f = std::log(texture_target / bytes_lo) / std::log(bytes_hi / bytes_lo);
        const int q = std::clamp(static_cast<int>(std::floor(q_lo + f * (q_hi - q_lo))), q_lo + 1, q_hi - 1);
        auto bq = bytes_at(q, scale);
        if (!bq) return bq.error();
        if (*bq <= texture_target) q_lo = q, bytes_lo = *bq;
        else q_hi = q, bytes_hi = *bq;
      }
    }
    if (encoded_q != q_lo || encoded_scale != scale)
      if (auto s = encode_texture(textured->mesh, source(scale), q_lo); !s) return s.error();
    b.jpeg_quality = q_lo;
    b.texture_scale = scale;
    if (auto s = measure(textured->mesh); !s) return s.error();
  }
  if (b.glb_bytes > 1.1 * target) b.rule = "over-budget";
  out.stages.push_back({"budget", "bytes", b.glb_bytes, ms_since(t0)});
  out.node.mesh = std::move(textured->mesh);
  out.atlas_stats = std::move(*textured);
  out.atlas_stats.mesh = Mesh{};
  return out;
}

Scene frame_scene(TexturedFrame frame, std::string extras_json) {
  Scene scene;
  scene.cameras.push_back(std::move(frame.camera));
  scene.nodes.push_back(std::move(frame.node));
  scene.extras_json = std::move(extras_json);
  return scene;
}

std::string choices_json(const TexturedFrame& f) {
  nlohmann::json j = {{"preset", to_string(f.preset)}, {"texture", to_string(f.atlas_stats.mode)}};
  if (f.budget.budget_bytes > 0) {
    const BudgetChoice& b = f.budget;
    j["budget"] = {{"budget_bytes", b.budget_bytes},   {"tolerance_factor", b.tolerance_factor},
                   {"jpeg_quality", b.jpeg_quality},   {"texture_scale", b.texture_scale},
                   {"geometry_bytes", b.geometry_bytes}, {"texture_bytes", b.texture_bytes},
                   {"glb_bytes", b.glb_bytes},         {"encodes", b.encodes},
                   {"rule", b.rule}};
  }
  return j.dump();
}

}  // namespace rgbdcast
