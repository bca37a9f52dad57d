#include "stream/keyframe_encoder.h"

#include <algorithm>
#include <nlohmann/json.hpp>

#include "pipeline/keyframe_glb.h"

namespace rgbdcast::stream {

FrameReductionOptions reduction_for_budget(const FrameReductionOptions& base, const FineReduction& fine,
                                           double budget_kb) {
  FrameReductionOptions o = base;
  if (fine.above_kb > 0 && budget_kb > fine.above_kb) {
    o.params.depth_mesh.tolerance_factor = std::min(o.params.depth_mesh.tolerance_factor, fine.tolerance);
    o.params.depth_mesh.simplify_px = std::min(o.params.depth_mesh.simplify_px, fine.simplify_px);
    o.budget_max_jpeg_quality = std::max(o.budget_max_jpeg_quality, fine.max_jpeg_quality);
  }
  return o;
}

Result<EncodedKeyframe> encode_keyframe(const RgbdFrame& frame, FrameReductionOptions options, double budget_kb,
                                        const Eigen::Matrix4d& camera_to_world,
                                        const std::vector<CoverageView>& earlier) {
  options.budget_kb = budget_kb;
  auto textured = reduce_and_texture(frame, options, camera_to_world, earlier);
  if (!textured) return textured.error();
  EncodedKeyframe out;
  out.triangles = textured->node.mesh.triangle_count();
  out.fits = textured->budget.rule == "fits";
  textured->node.to_world = Eigen::Matrix4d::Identity();
  textured->camera.camera_to_world = Eigen::Matrix4d::Identity();
  const nlohmann::json capture = {{"source", frame.color_path}, {"frame", frame.index}, {"timestamp", frame.timestamp}};
  auto glb = encode_keyframe_glb(std::move(*textured), capture, options.glb);
  if (!glb) return glb.error();
  out.glb = std::move(*glb);
  return out;
}

}  // namespace rgbdcast::stream
