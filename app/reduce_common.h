#pragma once
// What reduce (single frame and sequence) shares: its arguments, and the options they give the one frame -> scene
// function (pipeline/frame_scene.h).
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "atlas/atlas.h"
#include "gltf/gltf_io.h"
#include "input/frame.h"
#include "input/frame_source.h"
#include "keyframes/sequence.h"
#include "pipeline/frame_defaults.h"
#include "pipeline/frame_scene.h"
#include "reduction/pipeline.h"

namespace rgbdcast::app {

struct ReduceArgs {
  std::string input, depth, intrinsics, associations, out, report;
  int frame = 0;
  double depth_scale = 0;
  std::string depth_encoding = "png16";            // png16 | nyu | sun (input/depth_encoding.h)
  std::string preset = to_string(kDefaultPreset);  // realtime (pipeline/frame_defaults.h)
  // < 0: the preset's default (realtime: min(40 kB, a quarter of the frame's JPEG90+PNG16 payload), set per frame
  // by reduce_and_texture for each frame: budget_within_payload_share; paper: none).
  double budget_kb = -1;
  double budget_outline_texture_scale = FrameReductionOptions{}.budget_outline_texture_scale;
  int budget_max_jpeg_quality = FrameReductionOptions{}.budget_max_jpeg_quality;
  // --geometry-codec not given: the preset's default (default_geometry_codec: realtime draco, paper meshopt).
  bool geometry_codec_chosen = false;
  ReductionParams params;
  AtlasOptions atlas;
  std::string texture = "auto";
  GlbWriteOptions glb;
  // sequence mode
  bool sequence = false;
  int from = 0, to = -1;
  std::string features = "sift";
  std::string tracking = "robust";  // robust | paper | live (keyframes/tracker.h, SequenceParams::live)
  double keyframe_translation_m = 0.15, keyframe_rotation_deg = 10.0, keyframe_overlap = 0.7;
  int keyframe_gap = 0;
  bool drop_covered = true;
  bool progress = true;
  std::string trajectory;  // write the estimated trajectory here (.log: Redwood, else TUM)
};

// The frame -> scene options the arguments ask for (preset, texture mode, budget); errors name the bad option.
// Without --budget-kb, the realtime preset's budget is each frame's default (default_budget_kb: min(40 kB, a quarter
// of its JPEG90+PNG16 payload), which reduce_and_texture estimates: budget_within_payload_share).
Result<FrameReductionOptions> frame_options(const ReduceArgs& args);

// The sequence options the arguments ask for (features, keyframe rule, range); errors name the bad option. Shared
// by reduce --sequence and stream.
Result<SequenceParams> sequence_params(const ReduceArgs& args);

// The frame source options the arguments ask for (intrinsics, depth unit and encoding, pairing); errors name the bad
// option. Shared by reduce and stream.
Result<SourceOptions> source_options(const ReduceArgs& args, const RosbagTopics& topics);

nlohmann::json intrinsics_json(const Intrinsics& k);
nlohmann::json params_json(const ReduceArgs& args);

}  // namespace rgbdcast::app
