#pragma once
// What reduce (single frame and sequence) shares: its arguments and turning a frame into a textured scene node.
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "atlas/atlas.h"
#include "gltf/gltf_io.h"
#include "input/frame.h"
#include "reduction/coverage_filter.h"
#include "reduction/pipeline.h"
#include "scene/scene.h"

namespace rgbdcast::app {

struct ReduceArgs {
  std::string input, depth, intrinsics, associations, out, report;
  int frame = 0;
  double depth_scale = 0;
  ReductionParams params;
  AtlasOptions atlas;
  std::string texture = "auto";
  GlbWriteOptions glb;
  // sequence mode
  bool sequence = false;
  int from = 0, to = -1;
  std::string features = "sift";
  double keyframe_translation_m = 0.15, keyframe_rotation_deg = 10.0, keyframe_overlap = 0.7;
  int keyframe_gap = 0;
  bool drop_covered = true;
  bool progress = true;
  std::string trajectory;  // write the estimated trajectory here (.log: Redwood, else TUM)
};

struct TexturedFrame {
  SceneNode node;
  CaptureCamera camera;
  std::vector<StageReport> stages;  // reduction stages + atlas
  AtlasResult atlas_stats;          // without the mesh (moved into node)
};

// Reduces and textures one frame; the node and camera are placed at camera_to_world. With `earlier` views, the
// triangles they already cover are dropped before texturing (stage "covered").
Result<TexturedFrame> reduce_and_texture(const RgbdFrame& frame, const ReduceArgs& args,
                                         const Eigen::Matrix4d& camera_to_world,
                                         const std::vector<CoverageView>& earlier = {});

nlohmann::json intrinsics_json(const Intrinsics& k);
nlohmann::json params_json(const ReduceArgs& args);
// Writes bytes atomically (temp file + fsync + rename): nothing half-written is ever left behind.
Status write_file_atomic(const std::string& path, const std::vector<std::uint8_t>& bytes);

}  // namespace rgbdcast::app
