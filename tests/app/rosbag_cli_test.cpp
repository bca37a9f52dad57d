// rgbdcast reduce --input recording.bag as a user runs it: ROS 1 bags written at test time from the shared TUM fr1/xyz
// frames must reduce to what the folder reduces to; bad bags give one line and exit 2.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "tests/common/run_command.h"
#include "tests/common/test_data.h"
#include "tests/input/test_bags.h"

namespace fs = std::filesystem;

namespace rgbdcast {
namespace {

const char* kFr1 = "tum/rgbd_dataset_freiburg1_xyz";

class RosbagCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { dir_ = test::temp_dir("rosbag-cli"); }
  // One bag per name for the whole suite.
  static std::string bag(const std::string& name, const test::BagSpec& spec) {
    static std::map<std::string, test::MadeBag> made;
    auto it = made.find(name);
    if (it == made.end()) it = made.emplace(name, test::make_fr1_bag(dir_, name, spec)).first;
    EXPECT_TRUE(it->second.ok) << it->second.why_not;
    return it->second.path;
  }
  // Runs reduce and returns its report.
  static nlohmann::json reduce(const std::string& input, const std::string& args, const std::string& name) {
    const std::string out = dir_ + "/" + name + ".glb", report = dir_ + "/" + name + ".json";
    auto r = test::run_command(test::rgbdcast_binary() + " reduce --preset paper --input '" + input + "' " + args +
                               " --out " + out + " --report " + report);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    if (r.exit_code != 0) return nlohmann::json::object();
    std::ifstream in(report);
    return nlohmann::json::parse(in);
  }
  static std::string dir_;
};
std::string RosbagCli::dir_;

TEST_F(RosbagCli, Frame0ReducesToTheFolderTriangleCount) {
  REQUIRE_DATA(kFr1);
  REQUIRE_BAG_WRITER();
  const nlohmann::json folder = reduce(test::data_path(kFr1), "--frame 0", "folder0");
  ASSERT_TRUE(folder.contains("triangles"));
  const nlohmann::json metres = reduce(bag("f32", {test::BagDepth::kMetres32F, "rgb8"}), "--frame 0", "bag32f");
  const nlohmann::json raw =
      reduce(bag("raw16", {test::BagDepth::kTumRaw16U, "bgr8"}), "--frame 0 --depth-scale 5000", "bag16raw");
  const nlohmann::json mm = reduce(bag("mm16", {test::BagDepth::kMillimetres16U, "rgb8"}), "--frame 0", "bag16mm");
  for (const auto* j : {&metres, &raw}) {
    ASSERT_TRUE(j->contains("triangles"));
    EXPECT_EQ(j->at("triangles"), folder.at("triangles"));
    EXPECT_EQ(j->at("points"), folder.at("points"));
    EXPECT_EQ(j->at("intrinsics"), folder.at("intrinsics")) << "fr1's pinhole camera, from CameraInfo";
    EXPECT_NEAR(j->at("timestamp").get<double>(), folder.at("timestamp").get<double>(), 1e-6);
  }
  // Millimetre depth moves points by up to 0.5 mm: the same reduction to within a few per cent.
  ASSERT_TRUE(mm.contains("triangles"));
  const double ratio = mm.at("triangles").get<double>() / folder.at("triangles").get<double>();
  std::printf("[ triangles ] folder %d, bag 32FC1 %d, bag 16UC1 raw %d, bag 16UC1 mm %d\n",
              folder.at("triangles").get<int>(), metres.value("triangles", -1), raw.value("triangles", -1),
              mm.at("triangles").get<int>());
  EXPECT_NEAR(ratio, 1.0, 0.03);
}

TEST_F(RosbagCli, SequenceOfTheBagMatchesTheFolder) {
  REQUIRE_DATA(kFr1);
  REQUIRE_BAG_WRITER();
  // --keyframe-gap 1 makes every frame a keyframe: three reductions placed by tracking, not one.
  const std::string args = "--sequence --no-progress --keyframe-gap 1";
  const nlohmann::json folder = reduce(test::data_path(kFr1), args, "seq_folder");
  const nlohmann::json b = reduce(bag("f32", {test::BagDepth::kMetres32F, "rgb8"}), args, "seq_bag");
  ASSERT_TRUE(folder.contains("triangles") && b.contains("triangles"));
  EXPECT_EQ(folder.at("keyframes").size(), 3u);
  EXPECT_EQ(b.at("keyframes").size(), folder.at("keyframes").size());
  EXPECT_EQ(b.at("triangles"), folder.at("triangles"));
  ASSERT_EQ(b.at("frames").size(), folder.at("frames").size());
  for (size_t i = 0; i < folder.at("frames").size(); ++i) {
    const auto& fa = folder.at("frames")[i];
    const auto& fb = b.at("frames")[i];
    EXPECT_EQ(fb.at("matches"), fa.at("matches")) << "frame " << i;
    EXPECT_EQ(fb.at("inliers"), fa.at("inliers")) << "frame " << i;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c)
        EXPECT_NEAR(fb.at("pose")[r][c].get<double>(), fa.at("pose")[r][c].get<double>(), 1e-9) << i << r << c;
  }
}

class RosbagCliBad : public RosbagCli {
 protected:
  void expect_fails(const std::string& input, const std::string& args, const std::string& message) {
    const std::string out = dir_ + "/bad.glb";
    auto r = test::run_command(test::rgbdcast_binary() + " reduce --input '" + input + "' " + args + " --out " + out);
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_NE(r.err.find(message), std::string::npos) << "expected \"" << message << "\" in: " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(out));
  }
};

TEST_F(RosbagCliBad, MissingTopicListsTheBagsTopics) {
  REQUIRE_DATA(kFr1);
  REQUIRE_BAG_WRITER();
  const std::string b = bag("f32", {test::BagDepth::kMetres32F, "rgb8"});
  expect_fails(b, "--color-topic /camera/color/image_raw",
               "no topic /camera/color/image_raw (--color-topic); the bag has /camera/depth/image (sensor_msgs/Image, "
               "3 messages), /camera/rgb/camera_info (sensor_msgs/CameraInfo, 1 messages), /camera/rgb/image_color "
               "(sensor_msgs/Image, 4 messages)");
}

TEST_F(RosbagCliBad, UnsupportedEncoding) {
  REQUIRE_DATA(kFr1);
  REQUIRE_BAG_WRITER();
  expect_fails(bag("yuv", {test::BagDepth::kMetres32F, "yuv422"}), "", "colour encoding \"yuv422\" is not supported");
}

TEST_F(RosbagCliBad, TruncatedBag) {
  REQUIRE_DATA(kFr1);
  REQUIRE_BAG_WRITER();
  const std::string b = bag("f32", {test::BagDepth::kMetres32F, "rgb8"});
  const std::string cut = dir_ + "/cut.bag";
  fs::copy_file(b, cut, fs::copy_options::overwrite_existing);
  fs::resize_file(cut, fs::file_size(b) * 2 / 3);
  expect_fails(cut, "", "cut.bag: not a readable ROS 1 bag (truncated or corrupt");
}

}  // namespace
}  // namespace rgbdcast
