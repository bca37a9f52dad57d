#include "app/reduce_common.h"

#include <chrono>

#include "app/report.h"

namespace rgbdcast::app {

Result<TexturedFrame> reduce_and_texture(const RgbdFrame& frame, const ReduceArgs& args,
                                         const Eigen::Matrix4d& camera_to_world,
                                         const std::vector<CoverageView>& earlier) {
  auto reduced = reduce_frame(frame, args.params);
  if (!reduced) return reduced.error();
  TexturedFrame out;
  out.stages = reduced->stages;
  if (!earlier.empty()) {
    const auto t0 = std::chrono::steady_clock::now();
    drop_covered_triangles(reduced->mesh, camera_to_world, earlier);
    out.stages.push_back({"covered", "triangles", reduced->mesh.triangle_count(),
                          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count()});
    if (reduced->mesh.indices.empty()) return make_error(ErrorCode::kEmpty, "every triangle is covered by earlier keyframes");
  }
  AtlasOptions atlas = args.atlas;
  auto mode = parse_texture_mode(args.texture);
  if (!mode) return mode.error();
  atlas.mode = *mode;
  auto textured = build_atlas(reduced->mesh, frame.color_rgb, frame.intrinsics, atlas);
  if (!textured) return textured.error();
  out.stages.push_back({"atlas", "texels", textured->texels, textured->ms + textured->encode_ms});
  out.node.name = "keyframe_" + std::to_string(frame.index);
  out.node.mesh = std::move(textured->mesh);
  out.node.to_world = camera_to_world;
  out.atlas_stats = std::move(*textured);
  out.atlas_stats.mesh = Mesh{};
  out.camera.intrinsics = frame.intrinsics;
  out.camera.camera_to_world = camera_to_world;
  out.camera.timestamp = frame.timestamp;
  out.camera.source = frame.color_path;
  out.camera.frame_index = frame.index;
  return out;
}

nlohmann::json intrinsics_json(const Intrinsics& k) {
  return {{"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx}, {"cy", k.cy}, {"width", k.width}, {"height", k.height}};
}

nlohmann::json params_json(const ReduceArgs& a) {
  return {{"outliers", a.params.outlier_method == OutlierMethod::kKdTree ? "kdtree" : "organized"},
          {"outlier_k", a.params.outlier_k},
          {"outlier_std_mul", a.params.outlier_std_mul},
          {"voxel_size_m", a.params.voxel_size_m},
          {"max_edge_m", a.params.max_edge_m},
          {"perimeter_factor", a.params.perimeter_factor},
          {"simplify_error_m", a.params.simplify_error_m},
          {"texture", a.texture},
          {"cell_size_px", a.atlas.cell_size_px},
          {"jpeg_quality", a.atlas.jpeg_quality},
          {"meshopt", a.glb.meshopt},
          {"position_step_m", a.glb.position_quantum_m}};
}

}  // namespace rgbdcast::app
