#pragma once
// Keyframes for the mission tests: real frames of the 120-frame TUM fr1/xyz excerpt (../shared/data), each reduced by
// the real CLI (`rgbdcast reduce --preset realtime --budget-kb 12`, so the tests stay fast; the files come out at
// about 38 kB: the budget is not met at that size, which does not matter here) into a keyframe GLB in its
// own camera frame, with its ground-truth pose relative to the first one (the mission's world frame), in the wire
// order tx,ty,tz,qx,qy,qz,qw. Each frame is reduced once into mission_keyframe_cache() and read from there after.
#include <cstdint>
#include <string>
#include <vector>

namespace rgbdcast::test {

inline constexpr const char* kMissionExcerpt = "tum/rgbd_dataset_freiburg1_xyz_200_319";

struct MissionKeyframeFile {
  int frame = 0;          // index in the excerpt
  std::string glb;        // the GLB's bytes
  std::string pose;       // "tx,ty,tz,qx,qy,qz,qw"
  double captured = 0.0;  // the frame's timestamp
};

// The folder of the reduced keyframes: RGBDCAST_MISSION_KEYFRAMES_DIR when set, which ctest sets for the programs
// that need the mission_keyframes fixture (tests/service/CMakeLists.txt): the fixture fills it once per ctest run from
// the freshly built CLI, and every test reads the same files instead of reducing the frames again in each test's
// process. Unset (a test program run by hand), a temporary folder of this process's own. `rgbdcast reduce` renames its
// finished file into place, so processes that reduce a missing frame into the shared folder at once never see half
// of one.
std::string mission_keyframe_cache();
// The keyframes of `frames` (indices into the excerpt); empty with *error set when the data or the CLI fails.
std::vector<MissionKeyframeFile> mission_keyframes(const std::vector<int>& frames, std::string* error);
// Frames 0, 40, 80 and 119, made on first use and kept for the program; empty (with a test failure saying why)
// when they cannot be made.
const std::vector<MissionKeyframeFile>& four_mission_keyframes();

}  // namespace rgbdcast::test
