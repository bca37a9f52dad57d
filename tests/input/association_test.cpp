#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "input/frame_source.h"
#include "tests/common/test_data.h"

namespace rgbdcast {
namespace {

TEST(Association, PairsTheRealFr1XyzListsLikeAssociatePy) {
  REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz/rgb.txt");
  auto rgb = read_tum_list(test::data_path("tum/rgbd_dataset_freiburg1_xyz/rgb.txt"));
  auto depth = read_tum_list(test::data_path("tum/rgbd_dataset_freiburg1_xyz/depth.txt"));
  ASSERT_TRUE(rgb && depth);
  std::vector<FrameEntry> pairs = associate(*rgb, *depth, 0.02);
  ASSERT_GE(pairs.size(), 3u);
  for (const auto& p : pairs) EXPECT_LT(std::abs(p.color_timestamp - p.depth_timestamp), 0.02);
  for (size_t i = 1; i < pairs.size(); ++i) EXPECT_LT(pairs[i - 1].color_timestamp, pairs[i].color_timestamp);

  // The published association list of the whole sequence (made with associate.py) must agree on these frames.
  REQUIRE_DATA("tum/associations/fr1_xyz.txt");
  std::ifstream in(test::data_path("tum/associations/fr1_xyz.txt"));
  std::string line;
  size_t checked = 0;
  while (std::getline(in, line) && checked < pairs.size()) {
    std::istringstream ss(line);
    double tr, td;
    std::string pr, pd;
    ASSERT_TRUE(ss >> tr >> pr >> td >> pd);
    EXPECT_EQ(pr, pairs[checked].color_path) << "pair " << checked;
    EXPECT_EQ(pd, pairs[checked].depth_path) << "pair " << checked;
    ++checked;
  }
  EXPECT_EQ(checked, pairs.size());
}

TEST(Association, EachStampIsUsedOnceAndTheClosestWins) {
  std::vector<StampedPath> rgb{{1.000, "r1"}, {1.010, "r2"}, {2.000, "r3"}};
  std::vector<StampedPath> depth{{1.008, "d1"}, {2.5, "d2"}};
  auto pairs = associate(rgb, depth, 0.02);
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(pairs[0].color_path, "r2");  // |1.010 - 1.008| beats |1.000 - 1.008|
  EXPECT_EQ(pairs[0].depth_path, "d1");
}

TEST(Association, TimestampsOutOfOrderStillPair) {
  std::vector<StampedPath> rgb{{3.0, "r3"}, {1.0, "r1"}, {2.0, "r2"}};
  std::vector<StampedPath> depth{{2.001, "d2"}, {3.001, "d3"}, {1.001, "d1"}};
  auto pairs = associate(rgb, depth, 0.02);
  ASSERT_EQ(pairs.size(), 3u);
  EXPECT_EQ(pairs[0].depth_path, "d1");
  EXPECT_EQ(pairs[2].depth_path, "d3");
}

TEST(Association, MalformedListIsAClearError) {
  const std::string dir = test::temp_dir("tumlist");
  std::ofstream(dir + "/rgb.txt") << "# comment\n1.0 rgb/a.png\nbanana\n";
  auto r = read_tum_list(dir + "/rgb.txt");
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find(":3:"), std::string::npos) << r.error().message;
}

}  // namespace
}  // namespace rgbdcast
