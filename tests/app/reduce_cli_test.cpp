// The rgbdcast reduce command as a user runs it: real data in, GLB and report out; bad input gives one line on
// stderr, a non-zero exit and no output file.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "gltf/gltf_io.h"
#include "tests/common/run_command.h"
#include "tests/common/test_data.h"

namespace fs = std::filesystem;

namespace rgbdcast {
namespace {

std::string q(const std::string& s) { return "'" + s + "'"; }

TEST(ReduceCli, Fr1XyzFrame0WritesAGlbAndAReport) {
  REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz");
  const std::string dir = test::temp_dir("reduce-cli");
  auto r = test::run_command(test::rgbdcast_binary() + " reduce --preset paper --input " +
                             q(test::data_path("tum/rgbd_dataset_freiburg1_xyz")) +
                             " --frame 0 --intrinsics fr1 --out " + dir + "/f0.glb --report " + dir + "/f0.json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  ASSERT_TRUE(fs::exists(dir + "/f0.glb"));
  std::ifstream in(dir + "/f0.json");
  nlohmann::json j = nlohmann::json::parse(in);
  const auto& stages = j.at("stages");
  ASSERT_GE(stages.size(), 5u);
  const char* names[] = {"valid", "outliers", "voxel", "triangulate", "perimeter"};
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(stages[i].at("name"), names[i]);
    EXPECT_TRUE(stages[i].contains("ms"));
  }
  EXPECT_TRUE(stages[0].contains("points"));
  EXPECT_TRUE(stages[3].contains("triangles"));
  const long voxel = stages[2].at("points");
  EXPECT_GE(voxel, 10000);
  EXPECT_LE(voxel, 40000);
  EXPECT_GT(j.at("triangles").get<long>(), 10000);
  EXPECT_EQ(j.at("bytes").get<long>(), static_cast<long>(fs::file_size(dir + "/f0.glb")));
  EXPECT_GT(j.at("total_ms").get<double>(), 0.0);
  EXPECT_NE(r.out.find("triangulate"), std::string::npos) << "the stage table is printed";
  for (const auto& e : fs::directory_iterator(dir))
    EXPECT_EQ(e.path().string().find(".tmp"), std::string::npos) << "left behind: " << e.path();
}

// With no options, reduce runs the realtime preset (pipeline/frame_defaults.h) under its default budget, with Draco
// geometry: what the README and scripts/demo.sh promise.
TEST(ReduceCli, TheDefaultIsTheRealtimePresetUnderItsBudget) {
  REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz");
  const std::string dir = test::temp_dir("reduce-default");
  auto r = test::run_command(test::rgbdcast_binary() + " reduce --input " +
                             q(test::data_path("tum/rgbd_dataset_freiburg1_xyz")) + " --frame 0 --out " + dir +
                             "/f0.glb --report " + dir + "/f0.json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::ifstream in(dir + "/f0.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j.at("reduction").at("preset"), "realtime");
  EXPECT_EQ(j.at("params").at("geometry_codec"), "draco");
  // TUM fr1/xyz frame 0: its JPEG90+PNG16 payload is over 160 kB, so the budget is the 40 kB cap.
  EXPECT_DOUBLE_EQ(j.at("reduction").at("budget").at("budget_bytes").get<double>(), 40000.0);
  EXPECT_LE(j.at("bytes").get<long>(), 40000);
  EXPECT_LE(j.at("triangles").get<long>(), 20000);
  EXPECT_GT(j.at("triangles").get<long>(), 1000);
  std::vector<std::string> names;
  for (const auto& st : j.at("stages")) names.push_back(st.at("name"));
  EXPECT_NE(std::find(names.begin(), names.end(), "filter"), names.end()) << j.at("stages");
  EXPECT_EQ(std::find(names.begin(), names.end(), "voxel"), names.end()) << j.at("stages");
  EXPECT_NE(r.out.find("budget 40 kB"), std::string::npos) << r.out;
}

// The built-in sample (scripts/demo.sh) with the defaults: the realtime preset, a GLB well under the budget's cap,
// and a mesh that covers the sample's valid pixels (rgbdcast eval at the capture pose).
TEST(ReduceCli, RunsOnTheBuiltInSample) {
  const std::string dir = test::temp_dir("reduce-sample");
  auto mk = test::run_command(test::binary_path("assets/make_sample") + " " + dir + "/room 1");
  ASSERT_EQ(mk.exit_code, 0) << mk.err;
  auto r = test::run_command(test::rgbdcast_binary() + " reduce --input " + dir + "/room --intrinsics kinect --out " +
                             dir + "/room.glb --report " + dir + "/room.json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::ifstream in(dir + "/room.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j.at("reduction").at("preset"), "realtime");
  EXPECT_GT(fs::file_size(dir + "/room.glb"), 1000u);
  EXPECT_LE(fs::file_size(dir + "/room.glb"), 40000u);
  auto e = test::run_command(test::rgbdcast_binary() + " eval --input " + dir + "/room --intrinsics kinect --frame 0 " +
                             "--scene " + dir + "/room.glb");
  ASSERT_EQ(e.exit_code, 0) << e.err;
  const nlohmann::json fidelity = nlohmann::json::parse(e.out);
  EXPECT_GE(fidelity.at("coverage").get<double>(), 0.99) << e.out;
  EXPECT_GE(fidelity.at("psnr_db").get<double>(), 28.0) << e.out;  // 30.3 dB measured
}

struct BadCase {
  const char* name;
  std::string args;     // after "reduce"
  std::string message;  // expected in the one-line error
};

class ReduceCliBadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::temp_dir("reduce-bad");
    cv::imwrite(dir_ + "/c.png", cv::Mat(480, 640, CV_8UC3, cv::Scalar(10, 20, 30)));
    cv::imwrite(dir_ + "/d.png", cv::Mat(480, 640, CV_16UC1, cv::Scalar(5000)));
    cv::imwrite(dir_ + "/zero.png", cv::Mat(480, 640, CV_16UC1, cv::Scalar(0)));
    cv::imwrite(dir_ + "/d8.png", cv::Mat(480, 640, CV_8UC1, cv::Scalar(50)));
    cv::imwrite(dir_ + "/small.png", cv::Mat(240, 320, CV_16UC1, cv::Scalar(5000)));
    std::ofstream(dir_ + "/corrupt.png", std::ios::binary) << "\x89PNG\r\n\x1a\nthis is not a png";
    std::ofstream(dir_ + "/corrupt.pcd") << "VERSION 0.7\nFIELDS x y z\nrubbish\n";
  }
  void expect_fails(const std::string& args, const std::string& message) {
    const std::string out = dir_ + "/out.glb";
    auto r = test::run_command(test::rgbdcast_binary() + " reduce " + args + " --out " + out);
    EXPECT_NE(r.exit_code, 0) << args;
    EXPECT_NE(r.err.find("error: "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(message), std::string::npos) << "expected \"" << message << "\" in: " << r.err;
    // One line from rgbdcast (the last line of stderr), and no output file, not even a temporary one.
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(out)) << args;
    for (const auto& e : fs::directory_iterator(dir_))
      EXPECT_EQ(e.path().filename().string().find("out.glb"), std::string::npos) << e.path();
  }
  std::string dir_;
};

TEST_F(ReduceCliBadInput, MissingFile) {
  expect_fails("--input " + dir_ + "/nope.png --depth " + dir_ + "/d.png", "no such file");
}
TEST_F(ReduceCliBadInput, CorruptPng) {
  expect_fails("--input " + dir_ + "/corrupt.png --depth " + dir_ + "/d.png", "not a readable image");
}
TEST_F(ReduceCliBadInput, CorruptPcd) { expect_fails("--input " + dir_ + "/corrupt.pcd", "PCD"); }
TEST_F(ReduceCliBadInput, DepthNot16Bit) {
  expect_fails("--input " + dir_ + "/c.png --depth " + dir_ + "/d8.png", "16-bit");
}
TEST_F(ReduceCliBadInput, DifferentSizes) {
  expect_fails("--input " + dir_ + "/c.png --depth " + dir_ + "/small.png", "different sizes");
}
TEST_F(ReduceCliBadInput, AllZeroDepth) {
  expect_fails("--input " + dir_ + "/c.png --depth " + dir_ + "/zero.png", "no valid depth");
}
TEST_F(ReduceCliBadInput, NegativeVoxelSize) {
  expect_fails("--input " + dir_ + "/c.png --depth " + dir_ + "/d.png --voxel-size -0.01", "voxel size");
}
TEST_F(ReduceCliBadInput, ZeroVoxelSize) {
  expect_fails("--input " + dir_ + "/c.png --depth " + dir_ + "/d.png --voxel-size 0", "voxel size");
}
TEST_F(ReduceCliBadInput, FramePastTheEnd) {
  REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz");
  expect_fails("--input " + q(test::data_path("tum/rgbd_dataset_freiburg1_xyz")) + " --frame 7", "past the end");
}
TEST_F(ReduceCliBadInput, UnknownIntrinsics) {
  expect_fails("--input " + dir_ + "/c.png --depth " + dir_ + "/d.png --intrinsics fr9", "unknown intrinsics");
}
TEST_F(ReduceCliBadInput, UnknownDepthEncoding) {
  expect_fails("--input " + dir_ + "/c.png --depth " + dir_ + "/d.png --depth-encoding png8",
               "--depth-encoding must be");
}
// SUN's bit-rotated millimetres (3 m stored as 24000) read as plain millimetres: 24 m, refused with a hint.
TEST_F(ReduceCliBadInput, SunDepthReadAsPlainMillimetres) {
  cv::imwrite(dir_ + "/sun.png", cv::Mat(480, 640, CV_16UC1, cv::Scalar((3000 << 3) | (3000 >> 13))));
  expect_fails("--input " + dir_ + "/c.png --depth " + dir_ + "/sun.png --depth-scale 1000", "--depth-encoding sun");
}

// A SUN3D-style frame made here: camera-intrinsics.txt (a 3x3 matrix; the size comes from the image) and a depth PNG
// of bit-rotated millimetres, a wall at 2.5 m, reduced with --depth-encoding sun.
TEST(ReduceCli, ReadsASun3dFrameWithItsMatrixFile) {
  const std::string dir = test::temp_dir("reduce-sun3d");
  cv::Mat color(360, 480, CV_8UC3);
  for (int y = 0; y < color.rows; ++y)
    for (int x = 0; x < color.cols; ++x) color.at<cv::Vec3b>(y, x) = cv::Vec3b(x % 256, y % 256, (x + y) % 256);
  cv::imwrite(dir + "/color.png", color);
  cv::imwrite(dir + "/depth.png", cv::Mat(360, 480, CV_16UC1, cv::Scalar((2500 << 3) | (2500 >> 13))));
  std::ofstream(dir + "/camera-intrinsics.txt") << "400 0 239.5\n0 400 179.5\n0 0 1\n";
  auto r = test::run_command(test::rgbdcast_binary() + " reduce --input " + dir + "/color.png --depth " + dir +
                             "/depth.png --intrinsics " + dir + "/camera-intrinsics.txt --depth-encoding sun --out " +
                             dir + "/out.glb --report " + dir + "/report.json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::ifstream in(dir + "/report.json");
  const nlohmann::json report = nlohmann::json::parse(in);
  EXPECT_EQ(report["intrinsics"]["width"], 480);
  EXPECT_EQ(report["intrinsics"]["height"], 360);
  EXPECT_DOUBLE_EQ(report["intrinsics"]["fx"].get<double>(), 400.0);
  // Every vertex lies on the wall, z = 2.5 m in the camera's frame (a single frame's world), and the mesh spans the
  // image: x reaches +-2.5 * 239.5 / 400 = +-1.50 m at its left and right edges.
  auto scene = read_glb_file(dir + "/out.glb");
  ASSERT_TRUE(scene) << scene.error().message;
  ASSERT_GE(scene->vertex_count(), 3u);
  double x_min = 1e9, x_max = -1e9;
  for (const auto& node : scene->nodes)
    for (const auto& p : node.mesh.positions) {
      const Eigen::Vector3d w = (node.to_world * p.cast<double>().homogeneous()).head<3>();
      EXPECT_NEAR(w.z(), 2.5, 0.005);
      x_min = std::min(x_min, w.x()), x_max = std::max(x_max, w.x());
    }
  EXPECT_NEAR(x_min, -1.50, 0.03);
  EXPECT_NEAR(x_max, 1.50, 0.03);
}

}  // namespace
}  // namespace rgbdcast
