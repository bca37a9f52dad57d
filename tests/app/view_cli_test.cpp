// rgbdcast render and eval as a user runs them, on a real reduced frame.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "tests/common/run_command.h"
#include "tests/common/test_data.h"

namespace fs = std::filesystem;

namespace rgbdcast {
namespace {

const char* kFr1 = "tum/rgbd_dataset_freiburg1_xyz";

class ViewCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = test::temp_dir("view-cli");
    if (!fs::exists(test::data_path(kFr1))) return;
    for (const char* mode : {"atlas", "frame"}) {
      auto r = test::run_command(test::rgbdcast_binary() + " reduce --preset paper --input " + test::data_path(kFr1) +
                                 " --frame 0 --texture " + mode + " --out " + dir_ + "/" + mode + ".glb");
      ASSERT_EQ(r.exit_code, 0) << r.err;
    }
  }
  static nlohmann::json eval(const std::string& args) {
    auto r =
        test::run_command(test::rgbdcast_binary() + " eval --input " + test::data_path(kFr1) + " --frame 0 " + args);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return r.exit_code == 0 ? nlohmann::json::parse(r.out) : nlohmann::json::object();
  }
  static std::string dir_;
};
std::string ViewCli::dir_;

TEST_F(ViewCli, RenderAtTheCapturePoseWritesTheCapturedView) {
  REQUIRE_DATA(kFr1);
  for (const char* backend : {"vulkan", "osmesa"}) {
    const std::string png = dir_ + "/capture_" + backend + ".png", report = dir_ + "/r_" + backend + ".json";
    auto r =
        test::run_command(test::rgbdcast_binary() + " render --scene " + dir_ + "/atlas.glb --pose capture --backend " +
                          backend + " --out " + png + " --report " + report);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    cv::Mat img = cv::imread(png, cv::IMREAD_UNCHANGED);
    ASSERT_EQ(img.cols, 640);
    ASSERT_EQ(img.rows, 480);
    std::vector<cv::Mat> ch;
    cv::split(img, ch);
    ASSERT_EQ(ch.size(), 4u);
    const double covered = cv::countNonZero(ch[3]) / 307200.0;
    EXPECT_GT(covered, 0.5) << backend;  // the reduced mesh covers most of the view
    std::ifstream in(report);
    nlohmann::json j = nlohmann::json::parse(in);
    EXPECT_EQ(j.at("backend"), backend);
    for (const char* k : {"device", "upload_ms", "render_ms", "readback_ms"}) EXPECT_TRUE(j.contains(k)) << k;
  }
}

TEST_F(ViewCli, LookAtViewAndBadCameraArguments) {
  REQUIRE_DATA(kFr1);
  auto ok = test::run_command(test::rgbdcast_binary() + " render --scene " + dir_ + "/atlas.glb --eye -0.5,-0.4,-0.3 " +
                              "--target 0,0,1.5 --width 320 --height 240 --out " + dir_ + "/novel.jpg");
  ASSERT_EQ(ok.exit_code, 0) << ok.err;
  cv::Mat img = cv::imread(dir_ + "/novel.jpg");
  ASSERT_EQ(img.cols, 320);
  cv::Scalar mean, stddev;
  cv::meanStdDev(img, mean, stddev);
  EXPECT_GT(stddev[0], 10.0) << "not a blank image";
  const std::string base =
      test::rgbdcast_binary() + " render --scene " + dir_ + "/atlas.glb --out " + dir_ + "/bad.png ";
  for (const std::string& args :
       {std::string("--eye nan,0,0 --target 0,0,1"), std::string("--eye 0,0,0 --target 0,0,0"),
        std::string("--pose capture --width 0 --height 10"), std::string("--pose capture --width 9000 --height 10"),
        std::string("--eye 1,2 --target 0,0,1"), std::string("--pose capture --mode wireframe")}) {
    auto r = test::run_command(base + args);
    EXPECT_EQ(r.exit_code, 2) << args << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(dir_ + "/bad.png"));
  }
  auto missing =
      test::run_command(test::rgbdcast_binary() + " render --scene " + dir_ + "/nope.glb --out " + dir_ + "/x.png");
  EXPECT_EQ(missing.exit_code, 2);
  std::ofstream(dir_ + "/truncated.glb", std::ios::binary) << "glTF\x02\0\0\0";
  auto truncated = test::run_command(test::rgbdcast_binary() + " render --scene " + dir_ + "/truncated.glb --out " +
                                     dir_ + "/x.png");
  EXPECT_EQ(truncated.exit_code, 2) << truncated.err;
  EXPECT_NE(truncated.err.find("error:"), std::string::npos);
}

// The paper's claim, measured: the reduced mesh keeps the visual quality of the view.
TEST_F(ViewCli, EvalMeasuresFidelityAtTheCapturePose) {
  REQUIRE_DATA(kFr1);
  const nlohmann::json atlas = eval("--scene " + dir_ + "/atlas.glb");
  const nlohmann::json frame = eval("--scene " + dir_ + "/frame.glb");
  const nlohmann::json full = eval("--full-cloud --mode points");
  const nlohmann::json sparse = eval("--scene " + dir_ + "/atlas.glb --mode points --point-size 1");
  ASSERT_TRUE(atlas.contains("psnr_db") && frame.contains("psnr_db") && full.contains("psnr_db") &&
              sparse.contains("psnr_db"));
  // The full cloud at its own pose is the frame itself: exact.
  EXPECT_GT(full["psnr_db"].get<double>(), 60.0);
  EXPECT_NEAR(full["coverage"].get<double>(), 1.0, 1e-9);
  // The textured mesh: faithful where it covers, and it covers most of the valid view.
  EXPECT_GT(atlas["psnr_db"].get<double>(), 28.0);
  EXPECT_GT(atlas["ssim"].get<double>(), 0.7);
  EXPECT_GT(atlas["coverage"].get<double>(), 0.7);
  EXPECT_GT(frame["coverage"].get<double>(), 0.7);
  // The 22k-point cloud as 1-pixel splats leaves most of the view empty: why the paper renders a mesh.
  EXPECT_LT(sparse["coverage"].get<double>(), 0.5 * atlas["coverage"].get<double>());
}

}  // namespace
}  // namespace rgbdcast
