#pragma once
// The real captures of ../shared/data as the keyframes tests and bench see them: opened with the input module's
// open_frame_source (layout, intrinsics and depth unit guessed from the folder: Redwood/Open3D with
// camera_primesense.json and mm depth; ICL-NUIM with fy = +480, i.e. rgbdcast's y-down camera; TUM fr1 with its
// distortion, undistorted on load).
#include <memory>
#include <string>

#include "input/frame_source.h"
#include "keyframes/sequence.h"

namespace rgbdcast::test {

struct TestSequence {
  std::string name;
  std::shared_ptr<FrameSource> source;  // null when the data is missing (REQUIRE_DATA skips or fails first)
  std::string error;                    // why source is null
  size_t size() const { return source ? source->size() : 0; }
  FrameLoader loader() const;
};

TestSequence open_test_sequence(const std::string& name, const std::string& data_relative);
// 5 consecutive frames, 525/525/319.5/239.5 from camera_primesense.json, depth 1000 = 1 m.
TestSequence augmented_icl_sequence();
// 5 widely spaced frames, fx 481.2, fy +480, depth 5000 = 1 m.
TestSequence icl_nuim_sequence();
// 3 consecutive frames of fr1/xyz (rgb/depth associated within 20 ms), fr1 intrinsics and distortion.
TestSequence tum_fr1_xyz_sequence();

}  // namespace rgbdcast::test
