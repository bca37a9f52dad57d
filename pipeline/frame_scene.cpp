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

// Re-encodes the node's texture at a quality and scale (the mesh's UVs are relative, so a scaled texture needs no
// change to them).
Status encode_texture(Mesh& mesh, const Image& full, int quality, double scale) {
  Image im = full;
  if (scale < 1.0) {
    const cv::Mat src(full.height, full.width, CV_8UC3, const_cast<std::uint8_t*>(full.data.data()));
    cv::Mat small;
    cv::resize(src, small, cv::Size(std::max(1, int(std::lround(full.width * scale))),
                                    std::max(1, int(std::lround(full.height * scale)))),
               0, 0, cv::INTER_AREA);
    im = image_from_rgb_mat(small);
  }
  auto jpeg = encode_jpeg(im, quality);
  if (!jpeg) return jpeg.error();
  mesh.texture = std::move(im);
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
  auto textured = texture_at(tol0, &out.stages);
  if (!textured) return textured.error();

  if (options.budget_kb > 0) {
    const auto t0 = Clock::now();
    BudgetChoice& b = out.budget;
    b.budget_bytes = options.budget_kb * 1000.0;
    const double target = b.budget_bytes - kExtrasReserveBytes;
    b.tolerance_factor = tol0;
    const Image full_texture = textured->mesh.texture;
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
    // The scene's own need: default tolerance at the best quality (texture_at encoded it so).
    b.jpeg_quality = kMaxQuality;
    if (auto s = measure(textured->mesh); !s) return s.error();
    if (b.glb_bytes <= target) {
      b.rule = "fits";
    } else {
      // Geometry: at most its share of the budget. The triangle count is scaled to the bytes, and the tolerance is
      // found by bisection on the count alone, which costs no encoding.
      auto tolerance_for = [&](double want) {  // the smallest tolerance >= tol0 with at most `want` triangles
        if (prepared->hierarchy.count(tol0) <= want) return tol0;
        double lo = tol0, hi = tol0;
        while (prepared->hierarchy.count(hi) > want && hi < kMaxToleranceFactor) lo = hi, hi *= 2;
        hi = std::min(hi, kMaxToleranceFactor);
        for (int i = 0; i < 20 && hi / lo > 1.01; ++i) {
          const double mid = std::sqrt(lo * hi);
          (prepared->hierarchy.count(mid) > want ? lo : hi) = mid;
        }
        return hi;
      };
      auto remesh = [&](double tolerance) -> Status {
        std::vector<StageReport> stages;
        auto t = texture_at(tolerance, &stages);
        if (!t) return t.error();
        textured = std::move(t);
        out.stages = std::move(stages);
        b.tolerance_factor = tolerance;
        return measure(textured->mesh);  // its texture at the best quality, as texture_at encoded it
      };
      const double geometry_cap = options.budget_geometry_share * target;
      b.rule = "texture-fitted";
      if (b.geometry_bytes > geometry_cap) {
        const double triangles = static_cast<double>(textured->mesh.triangle_count());
        if (auto s = remesh(tolerance_for(triangles * geometry_cap / b.geometry_bytes)); !s) return s.error();
        b.rule = "geometry-capped";
        // The texture at its best quality may leave bytes over: they go back to the mesh, once.
        const double left = target - b.glb_bytes;
        if (left > 0.05 * target && b.tolerance_factor > tol0) {
          const double more = static_cast<double>(textured->mesh.triangle_count()) *
                              (b.geometry_bytes + 0.9 * left) / std::max<double>(1.0, b.geometry_bytes);
          if (auto s = remesh(tolerance_for(more)); !s) return s.error();
        }
      }
      // Texture: the largest quality (then, below kMinQuality, a smaller scale) whose bytes fit what is left.
      const double texture_target = target - (b.glb_bytes - b.texture_bytes);
      if (b.texture_bytes > texture_target) {  // else the best quality fits
        double scale = 1.0;
        int q_lo = kMinQuality, q_hi = kMaxQuality;  // q_lo fits (after scaling), q_hi does not
        for (;;) {
          if (auto s = encode_texture(textured->mesh, full_texture, kMinQuality, scale); !s) return s.error();
          ++b.encodes;
          if (textured->mesh.texture_encoded.size() <= texture_target || scale * 0.7 < kMinTextureScale) break;
          scale *= 0.7;
        }
        while (q_hi - q_lo > 2) {
          const int q = (q_lo + q_hi) / 2;
          if (auto s = encode_texture(textured->mesh, full_texture, q, scale); !s) return s.error();
          ++b.encodes;
          (textured->mesh.texture_encoded.size() <= texture_target ? q_lo : q_hi) = q;
        }
        if (auto s = encode_texture(textured->mesh, full_texture, q_lo, scale); !s) return s.error();
        b.jpeg_quality = q_lo;
        b.texture_scale = scale;
        if (auto s = measure(textured->mesh); !s) return s.error();
      }
      if (b.glb_bytes > 1.1 * target) b.rule = "over-budget";
    }
    out.stages.push_back({"budget", "bytes", b.glb_bytes, ms_since(t0)});
  }
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
