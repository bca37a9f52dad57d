// rgbdcast render --camera cam.json: a full camera as robots and viewers state it, on a real reduced frame. The same
// camera stated as JSON must give the same image as the capture pose or the look-at options, to the bit.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "gltf/gltf_io.h"
#include "scene/camera.h"
#include "tests/common/run_command.h"
#include "tests/common/test_data.h"

namespace fs = std::filesystem;

namespace rgbdcast {
namespace {

const char* kFr1 = "tum/rgbd_dataset_freiburg1_xyz";

// The camera file as a client writes it: the issue's keys, pose as 4 row lists.
std::string write_camera(const std::string& path, const ViewCamera& c) {
  nlohmann::json pose = nlohmann::json::array();
  for (int r = 0; r < 4; ++r)
    pose.push_back(
        {c.camera_to_world(r, 0), c.camera_to_world(r, 1), c.camera_to_world(r, 2), c.camera_to_world(r, 3)});
  std::ofstream(path) << nlohmann::json{{"fx", c.fx},       {"fy", c.fy},         {"cx", c.cx},  {"cy", c.cy},
                                        {"width", c.width}, {"height", c.height}, {"pose", pose}}
                             .dump(1);
  return path;
}

class CameraCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = test::temp_dir("camera-cli");
    if (!fs::exists(test::data_path(kFr1))) return;
    auto r = test::run_command(test::rgbdcast_binary() + " reduce --preset paper --input " + test::data_path(kFr1) +
                               " --frame 0 --out " + dir_ + "/f0.glb");
    ASSERT_EQ(r.exit_code, 0) << r.err;
  }
  static cv::Mat render(const std::string& args, const std::string& name) {
    const std::string png = dir_ + "/" + name + ".png";
    auto r =
        test::run_command(test::rgbdcast_binary() + " render --scene " + dir_ + "/f0.glb " + args + " --out " + png);
    EXPECT_EQ(r.exit_code, 0) << args << "\n" << r.err;
    return cv::imread(png, cv::IMREAD_UNCHANGED);
  }
  static std::string dir_;
};
std::string CameraCli::dir_;

TEST_F(CameraCli, TheCaptureCameraAsJsonReproducesPoseCaptureExactly) {
  REQUIRE_DATA(kFr1);
  auto scene = read_glb_file(dir_ + "/f0.glb");
  ASSERT_TRUE(scene) << scene.error().message;
  ASSERT_FALSE(scene->cameras.empty());
  const ViewCamera capture = ViewCamera::from_capture(scene->cameras.front());
  const std::string cam = write_camera(dir_ + "/capture.json", capture);
  for (const char* backend : {"vulkan", "osmesa"}) {
    const std::string b = std::string(" --backend ") + backend;
    const cv::Mat a = render("--pose capture" + b, std::string("capture_") + backend);
    const cv::Mat c = render("--camera " + cam + b, std::string("camera_") + backend);
    ASSERT_FALSE(a.empty());
    ASSERT_EQ(a.size(), c.size());
    ASSERT_EQ(a.type(), c.type());
    EXPECT_EQ(cv::norm(a, c, cv::NORM_INF), 0.0) << backend;
    std::vector<cv::Mat> ch;
    cv::split(a, ch);
    EXPECT_GT(cv::countNonZero(ch[3]), 150000) << "not a blank image: " << backend;
  }
}

TEST_F(CameraCli, ALookAtCameraAsJsonReproducesEyeAndTarget) {
  REQUIRE_DATA(kFr1);
  const Eigen::Vector3d eye(-0.5, -0.4, -0.3), target(0, 0, 1.5), up(0, -1, 0);
  auto look = ViewCamera::look_at(eye, target, up, 55.0, 480, 360);
  ASSERT_TRUE(look) << look.error().message;
  const std::string cam = write_camera(dir_ + "/look.json", *look);
  const cv::Mat a = render("--eye -0.5,-0.4,-0.3 --target 0,0,1.5 --fov 55 --width 480 --height 360", "look_opts");
  const cv::Mat c = render("--camera " + cam, "look_json");
  ASSERT_FALSE(a.empty());
  ASSERT_EQ(a.size(), cv::Size(480, 360));
  ASSERT_EQ(a.size(), c.size());
  EXPECT_EQ(cv::norm(a, c, cv::NORM_INF), 0.0);
}

// 179 degrees is the documented maximum of --fov (and of the service's fov=, scene/camera.h): it renders; past it,
// one line and exit 2.
TEST_F(CameraCli, FovRendersUpToTheDocumentedMaximum) {
  REQUIRE_DATA(kFr1);
  const cv::Mat wide = render("--eye 0,0,0 --target 0,0,1 --fov 179 --width 64 --height 48", "fov179");
  ASSERT_EQ(wide.size(), cv::Size(64, 48));
  auto r = test::run_command(test::rgbdcast_binary() + " render --scene " + dir_ +
                             "/f0.glb --eye 0,0,0 --target 0,0,1 --fov 179.5 --out " + dir_ + "/fov179.5.png");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("at most 179 degrees"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_FALSE(fs::exists(dir_ + "/fov179.5.png"));
}

TEST_F(CameraCli, BadCameraFilesGiveOneLineAndExit2) {
  REQUIRE_DATA(kFr1);
  ViewCamera scaled;
  scaled.camera_to_world(0, 0) = 2.0;  // a scale, not a rotation
  const std::string cases[][2] = {
      {write_camera(dir_ + "/scaled.json", scaled), "'pose' rotation is not a rotation"},
      {dir_ + "/nope.json", "cannot open"},
  };
  std::ofstream(dir_ + "/text.json") << "{\"fx\": 500,";
  std::ofstream(dir_ + "/nofocal.json") << R"({"fx": 0, "fy": 500, "cx": 320, "cy": 240, "width": 640, "height": 480,
    "pose": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]})";
  auto check = [&](const std::string& file, const std::string& msg, const std::string& extra = "") {
    auto r = test::run_command(test::rgbdcast_binary() + " render --scene " + dir_ + "/f0.glb --camera " + file +
                               extra + " --out " + dir_ + "/bad.png");
    EXPECT_EQ(r.exit_code, 2) << file;
    EXPECT_NE(r.err.find(msg), std::string::npos) << "expected \"" << msg << "\" in: " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(dir_ + "/bad.png"));
  };
  for (const auto& c : cases) check(c[0], c[1]);
  check(dir_ + "/text.json", "text.json: not valid JSON");
  check(dir_ + "/nofocal.json", "'fx' and 'fy' must be positive");
  check(dir_ + "/scaled.json", "--camera excludes --pose", " --pose capture");
}

}  // namespace
}  // namespace rgbdcast
