#include "pipeline/frame_scene.h"

#include <algorithm>
#include <cmath>

#include "base/stopwatch.h"
#include "pipeline/budget_search.h"
#include "pipeline/frame_defaults.h"

namespace rgbdcast {

namespace {

TextureMode resolve_texture(const FrameReductionOptions& o) {
  if (o.texture != TextureMode::kAuto) return o.texture;
  return o.params.preset == Preset::kRealtime ? TextureMode::kFrame : TextureMode::kAuto;
}

}  // namespace

void FrameReductionOptions::use_budget(Preset preset, double asked_kb) {
  const bool default_budget = asked_kb < 0 && preset == Preset::kRealtime;
  budget_kb = asked_kb >= 0 ? asked_kb : (default_budget ? kDefaultBudgetKb : 0.0);
  budget_within_payload_share = default_budget;
}

Status FrameReductionOptions::validate() const {
  if (auto st = params.validate(); !st) return st;
  if (atlas.jpeg_quality < 1 || atlas.jpeg_quality > 100)
    return make_error(ErrorCode::kInvalidArgument, "JPEG quality must be 1..100");
  if (!(std::isfinite(budget_kb) && budget_kb >= 0 && budget_kb <= 100000))
    return make_error(ErrorCode::kInvalidArgument, "budget must be 0 (none) or up to 100000 kB");
  if (budget_kb > 0 && budget_kb < 4)
    return make_error(ErrorCode::kInvalidArgument, "budget must be at least 4 kB (a GLB's headers and a texture)");
  if (!(std::isfinite(budget_outline_texture_scale) && budget_outline_texture_scale >= kBudgetMinTextureScale &&
        budget_outline_texture_scale <= 1))
    return make_error(ErrorCode::kInvalidArgument, "the budget's outline texture scale must be 0.25..1");
  if (!(std::isfinite(budget_geometry_share) && budget_geometry_share > 0 && budget_geometry_share < 1))
    return make_error(ErrorCode::kInvalidArgument, "the budget's geometry share must be between 0 and 1");
  if (budget_max_jpeg_quality < kBudgetMinJpegQuality || budget_max_jpeg_quality > 100)
    return make_error(ErrorCode::kInvalidArgument, "the budget's best JPEG quality must be 20..100");
  if (budget_kb > 0 && params.preset != Preset::kRealtime)
    return make_error(ErrorCode::kInvalidArgument, "a byte budget needs the realtime preset (--preset realtime)");
  return ok_status();
}

Result<TexturedFrame> reduce_and_texture(const RgbdFrame& frame, const FrameReductionOptions& options,
                                         const Eigen::Matrix4d& camera_to_world,
                                         const std::vector<CoverageView>& earlier) {
  if (auto st = options.validate(); !st) return st.error();
  const int max_quality = options.budget_max_jpeg_quality;  // the best JPEG quality the budget tries
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
  // A budget encodes the texture once it has chosen the quality (the geometry is measured without it).
  atlas.encode = options.budget_kb <= 0;
  // A budget starts from the best quality, so the texture is encoded once at it, not again.
  if (options.budget_kb > 0) atlas.jpeg_quality = max_quality;
  // Draco's edgebreaker orders the triangles itself: meshoptimizer's vertex-cache order (for meshopt's delta
  // codecs) would be spent for nothing.
  if (!atlas.reorder_triangles && options.glb.flavor == GlbFlavor::kCompact &&
      options.glb.geometry_codec == GeometryCodec::kDraco)
    atlas.reorder_triangles = false;
  // The realtime preset spends no texture bytes on pixels no triangle samples (they are filled smoothly).
  if (options.params.preset == Preset::kRealtime && !atlas.fill_unsampled) atlas.fill_unsampled = true;

  // Mesh at a tolerance -> covered triangles dropped -> textured. The realtime preset prepares its hierarchy once.
  Result<RealtimeReduction> prepared = make_error(ErrorCode::kInternal, "not prepared");
  double budget_kb = options.budget_kb;
  if (options.params.preset == Preset::kRealtime) {
    // The payload's share, before the depth's preparation: made beside it on a second thread, it took as long
    // (its two encodes compete with the preparation's two threads; BENCHMARKS.md, "Realtime preset against the paper
    // preset").
    if (options.budget_within_payload_share && budget_kb > 0) {
      auto payload_kb = payload_share_kb(frame);
      if (!payload_kb) return payload_kb.error();
      budget_kb = std::min(budget_kb, *payload_kb);
    }
    prepared = prepare_realtime(frame, options.params);
    if (!prepared) return prepared.error();
  }
  auto texture_at = [&](double tolerance, double simplify_px, std::vector<StageReport>* stages) -> Result<AtlasResult> {
    Result<ReducedFrame> reduced =
        prepared ? extract_realtime(*prepared, frame, tolerance, simplify_px) : reduce_frame(frame, options.params);
    if (!reduced) return reduced.error();
    *stages = reduced->stages;
    if (!earlier.empty()) {
      const auto t0 = SteadyClock::now();
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
  if (budget_kb <= 0) {
    auto textured = texture_at(tol0, -1, &out.stages);
    if (!textured) return textured.error();
    out.node.mesh = std::move(textured->mesh);
    out.atlas_stats = std::move(*textured);
    out.atlas_stats.mesh = Mesh{};
    return out;
  }

  if (auto st = meet_budget({frame, options, camera_to_world, earlier, *prepared, atlas, budget_kb, texture_at}, &out);
      !st)
    return st.error();
  return out;
}

GlbWriteOptions write_options(const TexturedFrame& frame, GlbWriteOptions base) {
  if (frame.geometry_cache && !base.draco.cache) base.draco.cache = frame.geometry_cache;
  return base;
}

Scene frame_scene(TexturedFrame frame, std::string extras_json) {
  Scene scene;
  scene.cameras.push_back(std::move(frame.camera));
  scene.nodes.push_back(std::move(frame.node));
  scene.extras_json = std::move(extras_json);
  return scene;
}

}  // namespace rgbdcast
