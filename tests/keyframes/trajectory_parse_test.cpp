// The trajectory parsers on text from memory: the same results as the file readers, and hostile lines
// (an index past int, non-numbers, truncated matrices) are one-line errors or skipped lines, never UB.
#include <gtest/gtest.h>

#include <fstream>

#include "keyframes/trajectory_io.h"
#include "tests/common/test_data.h"

namespace rgbdcast {
namespace {

TEST(TrajectoryParse, MatchesTheFileReaderOnTumGroundTruth) {
  const char* rel = "tum/rgbd_dataset_freiburg1_xyz_200_319/groundtruth.txt";
  REQUIRE_DATA(rel);
  std::ifstream in(test::data_path(rel));
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto from_text = parse_trajectory(text, TrajectoryFormat::kTum, "gt");
  auto from_file = read_tum_trajectory(test::data_path(rel));
  ASSERT_TRUE(from_text && from_file);
  ASSERT_EQ(from_text->poses.size(), 587u);  // the data's README
  EXPECT_EQ(from_text->poses.size(), from_file->poses.size());
  EXPECT_TRUE(from_text->poses.back().camera_to_world.isApprox(from_file->poses.back().camera_to_world, 0.0));
}

TEST(TrajectoryParse, HostileTextIsAnErrorNotUndefinedBehaviour) {
  const std::string rot = "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n";
  // A frame index a double holds but an int does not (casting it would be undefined behaviour).
  for (const std::string head : {"1e300 0 1\n", "-1 0 1\n", "2.5 0 1\n", "2147483648 0 1\n"}) {
    auto r = parse_trajectory(head + rot, TrajectoryFormat::kRedwood, "t.log");
    ASSERT_FALSE(r) << head;
    EXPECT_EQ(r.error().message, "t.log:1: frame index is not a non-negative integer");
  }
  auto ok = parse_trajectory("2147483647 0 1\n" + rot, TrajectoryFormat::kRedwood, "t.log");
  ASSERT_TRUE(ok) << ok.error().message;
  EXPECT_EQ(ok->poses[0].index, 2147483647);
  auto cut = parse_trajectory("0 0 1\n1 0 0 0\n", TrajectoryFormat::kRedwood, "t.log");
  ASSERT_FALSE(cut);
  EXPECT_EQ(cut.error().message, "t.log: truncated matrix after line 2");
  // TUM: bad lines are skipped with a warning; nothing valid is an error.
  auto tum = parse_trajectory("1 0 0 0 0 0 0 1\nnan 0 0 0 0 0 0 1\n2 0 0 0 0 0 0 0\n", TrajectoryFormat::kTum, "gt");
  ASSERT_TRUE(tum);
  EXPECT_EQ(tum->poses.size(), 1u);
  EXPECT_EQ(tum->warnings.size(), 2u);
  EXPECT_FALSE(parse_trajectory(std::string("\0\xff\n", 3), TrajectoryFormat::kIcl, "p"));
}

}  // namespace
}  // namespace rgbdcast
