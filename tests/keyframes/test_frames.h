#pragma once
// Frames of the real captures in ../shared/data for the keyframes tests and bench, read directly with OpenCV
// (colour -> RGB, 16-bit depth -> metres, TUM fr1 undistorted with its published distortion). To be replaced by the
// input module's open_frame_source once it is on main.
#include <string>
#include <vector>

#include "input/frame.h"
#include "keyframes/sequence.h"
#include "scene/intrinsics.h"
#include "scene/result.h"

namespace rgbdcast::test {

struct FramePaths {
  std::string color, depth;
  double timestamp = 0.0;
};

struct TestSequence {
  std::string name;
  Intrinsics intrinsics;  // pinhole after undistortion is what frames carry; distortion applied on load
  std::vector<FramePaths> frames;
  FrameLoader loader() const;
};

// Loads one frame: colour (any 8-bit image) and a 16-bit depth PNG scaled by intrinsics.depth_scale.
Result<RgbdFrame> load_rgbd(const FramePaths& paths, const Intrinsics& intrinsics, int index);

// 5 consecutive frames, 525/525/319.5/239.5 read from camera_primesense.json, depth 1000 = 1 m.
TestSequence augmented_icl_sequence();
// 5 widely spaced frames, fx 481.2, fy +480 (rgbdcast's y-down convention; ICL's files say -480), depth 5000 = 1 m.
TestSequence icl_nuim_sequence();
// 3 consecutive frames of fr1/xyz (rgb/depth pairs from rgb.txt/depth.txt in order), fr1 intrinsics and distortion.
TestSequence tum_fr1_xyz_sequence();

}  // namespace rgbdcast::test
