// The mission_keyframes fixture of ctest (tests/service/CMakeLists.txt): it reduces the excerpt frames that the
// mission, tile and page tests post, once per ctest run, into the shared folder RGBDCAST_MISSION_KEYFRAMES_DIR, with
// the CLI just built. Whatever an earlier run left there is removed first: it may come from an older CLI.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "tests/common/test_data.h"
#include "tests/service/mission_keyframes.h"

namespace rgbdcast {
namespace {

TEST(MissionKeyframesFixture, TheFramesTheMissionTestsPostAreReducedOncePerRun) {
  std::string groundtruth = test::kMissionExcerpt;
  groundtruth += "/groundtruth.txt";  // appended: GCC 12's -Warray-bounds false positive (CMakeLists.txt)
  REQUIRE_DATA(groundtruth);
  const char* dir = std::getenv("RGBDCAST_MISSION_KEYFRAMES_DIR");
  ASSERT_TRUE(dir && *dir) << "RGBDCAST_MISSION_KEYFRAMES_DIR is not set: ctest sets it for this fixture";
  std::filesystem::remove_all(dir);
  const std::vector<int> frames = {0, 30, 40, 60, 80, 90, 119};
  std::string error;
  const auto keyframes = test::mission_keyframes(frames, &error);
  ASSERT_EQ(keyframes.size(), frames.size()) << error;
  for (size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(keyframes[i].frame, frames[i]);
    EXPECT_EQ(keyframes[i].glb.substr(0, 4), "glTF") << "frame " << frames[i];
    EXPECT_TRUE(std::filesystem::exists(std::string(dir) + "/kf" + std::to_string(frames[i]) + ".glb"));
  }
}

}  // namespace
}  // namespace rgbdcast
