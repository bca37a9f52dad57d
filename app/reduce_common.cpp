#include "app/reduce_common.h"

namespace rgbdcast::app {

Result<FrameReductionOptions> frame_options(const ReduceArgs& a) {
  FrameReductionOptions o;
  auto preset = parse_preset(a.preset);
  if (!preset) return preset.error();
  o.params = a.params;
  o.params.preset = *preset;
  auto mode = parse_texture_mode(a.texture);
  if (!mode) return mode.error();
  o.texture = *mode;
  o.atlas = a.atlas;
  o.glb = a.glb;
  if (!a.geometry_codec_chosen) o.glb.geometry_codec = default_geometry_codec(*preset);
  o.use_budget(*preset, a.budget_kb);  // the realtime default: each frame its own, estimated by reduce_and_texture
  o.budget_outline_texture_scale = a.budget_outline_texture_scale;
  o.budget_max_jpeg_quality = a.budget_max_jpeg_quality;
  if (auto st = o.validate(); !st) return st.error();
  return o;
}

Result<SequenceParams> sequence_params(const ReduceArgs& a) {
  SequenceParams params;
  if (a.tracking == "paper")
    params.tracking = TrackingParams::paper_window_only();
  else if (a.tracking == "live")
    params = SequenceParams::live();
  else if (a.tracking != "robust")
    return make_error(ErrorCode::kInvalidArgument, "--tracking must be robust, paper or live");
  auto features = parse_feature_type(a.features);
  if (!features) return features.error();
  params.odometry.features.type = *features;
  params.keyframes.max_translation_m = a.keyframe_translation_m;
  params.keyframes.max_rotation_deg = a.keyframe_rotation_deg;
  params.keyframes.min_overlap = a.keyframe_overlap;
  params.keyframes.max_frame_gap = a.keyframe_gap;
  if (auto st = params.keyframes.validate(); !st) return st.error();
  if (a.from < 0) return make_error(ErrorCode::kInvalidArgument, "--from must be 0 or more");
  params.from = static_cast<size_t>(a.from);
  if (a.to >= 0) params.to = static_cast<size_t>(a.to);
  return params;
}

Result<SourceOptions> source_options(const ReduceArgs& a, const RosbagTopics& topics) {
  SourceOptions so;
  so.rosbag = topics;
  so.intrinsics = a.intrinsics;
  so.depth_path = a.depth;
  so.associations_path = a.associations;
  if (a.depth_scale != 0) so.depth_scale = a.depth_scale;
  auto encoding = parse_depth_encoding(a.depth_encoding);
  if (!encoding) return make_error(ErrorCode::kInvalidArgument, "--depth-encoding must be png16, nyu or sun");
  so.depth_encoding = *encoding;
  return so;
}

nlohmann::json intrinsics_json(const Intrinsics& k) {
  return {{"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx}, {"cy", k.cy}, {"width", k.width}, {"height", k.height}};
}

nlohmann::json params_json(const ReduceArgs& a) {
  nlohmann::json j = {{"preset", a.preset},
                      // as asked: "default" when not given (the budget used is in the reduction's "budget")
                      {"budget_kb", a.budget_kb >= 0 ? nlohmann::json(a.budget_kb) : nlohmann::json("default")},
                      {"tolerance_factor", a.params.depth_mesh.tolerance_factor},
                      {"depth_noise", a.params.depth_mesh.noise_m_per_m2},
                      {"jump_relative", a.params.depth_mesh.jump_relative},
                      {"tile_px", a.params.depth_mesh.tile_px},
                      {"simplify_px", a.params.depth_mesh.simplify_px},
                      {"boundary_lost_px", a.params.depth_mesh.boundary_max_lost_px},
                      {"speckle_px", a.params.filter.min_region_px},
                      {"outliers", a.params.outlier_method == OutlierMethod::kKdTree ? "kdtree" : "organized"},
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
                      {"geometry_codec", to_string(a.geometry_codec_chosen || a.preset != "realtime"
                                                       ? a.glb.geometry_codec
                                                       : default_geometry_codec(Preset::kRealtime))},
                      {"position_step_m", a.glb.position_quantum_m}};
  return j;
}

}  // namespace rgbdcast::app
