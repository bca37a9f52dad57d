#pragma once
// What the pipeline's tests reduce: the realtime preset as `rgbdcast reduce --budget-kb B` runs it, and a frame of
// the shared TUM fr1/xyz capture.
#include <cstddef>

#include "input/frame_source.h"
#include "pipeline/frame_defaults.h"
#include "pipeline/frame_scene.h"
#include "tests/common/test_data.h"

namespace rgbdcast::test {

// The realtime preset with its default codec (Draco) at budget_kb (0: none).
inline FrameReductionOptions realtime(double budget_kb) {
  FrameReductionOptions o;
  o.params = reduction_preset(Preset::kRealtime);
  o.glb.geometry_codec = default_geometry_codec(Preset::kRealtime);
  o.budget_kb = budget_kb;
  return o;
}

// Frame `index` of tum/rgbd_dataset_freiburg1_xyz with the fr1 intrinsics (the caller checks REQUIRE_DATA).
inline Result<RgbdFrame> fr1_xyz_frame(size_t index) {
  SourceOptions so;
  so.intrinsics = "fr1";
  auto src = open_frame_source(data_path("tum/rgbd_dataset_freiburg1_xyz"), so);
  if (!src) return src.error();
  return (*src)->frame(index);
}

}  // namespace rgbdcast::test
