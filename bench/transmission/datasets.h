#pragma once
// The test cases: which frame is sent and at which real views the receiver's copy is judged.
//  - Augmented ICL-NUIM living room: frame 0 sent; novel views at the ground-truth poses of frames 1..4
//    (trajectory.log, camera-to-world), relative to frame 0: inverse(T0) * Tk.
//  - TUM fr1/xyz: frame 0 sent; frames 1 and 2 have no ground truth in the shared data, so their poses relative to
//    frame 0 are ESTIMATED with the keyframes module's frame odometry (SIFT + RANSAC + ICP).
#include <string>
#include <vector>

#include "bench/transmission/fidelity.h"
#include "input/frame.h"
#include "scene/result.h"

namespace rgbdcast::bench {

struct TestCase {
  std::string name;
  std::string folder;
  RgbdFrame sent;                    // frame 0
  std::vector<ReferenceView> views;  // [0] capture pose, then novel views
  std::vector<std::string> notes;    // where the poses came from, their size, odometry checks
};

Result<TestCase> load_icl_case(const std::string& data_dir);
// ICL-NUIM living room (icl_nuim_livingroom): frame 0 sent; novel views at pose.txt's poses of frames 1..4 (widely
// spaced: 24-49 deg from frame 0).
Result<TestCase> load_icl_nuim_case(const std::string& data_dir);
Result<TestCase> load_tum_case(const std::string& data_dir);
// TUM fr1/xyz frames 200-319 (tum/rgbd_dataset_freiburg1_xyz_200_319): its frame 0 sent, novel views at the
// ground-truth poses (groundtruth.txt, nearest within 0.02 s) of the frames listed.
Result<TestCase> load_tum_groundtruth_case(const std::string& data_dir, const std::vector<int>& novel);

}  // namespace rgbdcast::bench
