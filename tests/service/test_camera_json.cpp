// The full camera of view requests (service/camera_json.h) and its camera= query parameter: strict parsing, exact
// round trip, one-line errors for hostile input.
#include <gtest/gtest.h>

#include <cmath>

#include "service/camera_json.h"
#include "service/view_params.h"

namespace rgbdcast::service {
namespace {

const char* kValid = R"({"fx": 517.3, "fy": 516.5, "cx": 318.6, "cy": 255.3, "width": 640, "height": 480,
  "pose": [[0.8660254037844387, 0, 0.5, 0.1], [0, 1, 0, -0.2], [-0.5, 0, 0.8660254037844387, 0.3], [0, 0, 0, 1]]})";

TEST(CameraJson, ParsesTheIssueFormat) {
  auto c = parse_camera_json(kValid, kMaxViewSize);
  ASSERT_TRUE(c) << c.error().message;
  EXPECT_EQ(c->fx, 517.3);
  EXPECT_EQ(c->fy, 516.5);
  EXPECT_EQ(c->cx, 318.6);
  EXPECT_EQ(c->cy, 255.3);
  EXPECT_EQ(c->width, 640);
  EXPECT_EQ(c->height, 480);
  EXPECT_EQ(c->camera_to_world(0, 2), 0.5) << "row-major: row 0, column 2";
  EXPECT_EQ(c->camera_to_world(2, 0), -0.5);
  EXPECT_EQ(c->camera_to_world(1, 3), -0.2) << "translation in the last column";
  // world_to_camera inverts it: the camera centre maps to the origin.
  const Eigen::Vector4d centre = c->world_to_camera() * Eigen::Vector4d(0.1, -0.2, 0.3, 1.0);
  EXPECT_LT(centre.head<3>().norm(), 1e-12);
}

TEST(CameraJson, RoundTripsExactly) {
  ViewCamera c;
  c.fx = 1.0 / 3.0 * 1000;
  c.fy = 481.2;
  c.cx = 319.5;
  c.cy = 239.5;
  c.width = 800;
  c.height = 600;
  c.camera_to_world.topLeftCorner<3, 3>() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).matrix();
  c.camera_to_world.topRightCorner<3, 1>() = Eigen::Vector3d(1.0 / 7, -2.5, 3.25);
  auto back = parse_camera_json(camera_json(c), kMaxViewSize);
  ASSERT_TRUE(back) << back.error().message;
  EXPECT_EQ(back->fx, c.fx);
  EXPECT_EQ(back->fy, c.fy);
  EXPECT_EQ(back->width, c.width);
  EXPECT_EQ(back->camera_to_world, c.camera_to_world);
}

struct Bad {
  std::string json, message;
};

TEST(CameraJson, RejectsWhatIsNotACamera) {
  const std::string pose = R"("pose": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]])";
  const std::string k = R"("fx": 500, "fy": 500, "cx": 320, "cy": 240, )";
  const std::string size = R"("width": 640, "height": 480, )";
  const Bad cases[] = {
      {"", "not valid JSON"},
      {"[1,2]", "must be a JSON object"},
      {"{" + k + R"("width": 640, "height": 480})", "missing 'pose'"},
      {"{" + k + size + pose + R"(, "near": 0.1})", "unknown key 'near'"},
      {R"({"fx": "500", "fy": 500, "cx": 320, "cy": 240, )" + size + pose + "}", "'fx' must be a number"},
      {R"({"fx": -500, "fy": 500, "cx": 320, "cy": 240, )" + size + pose + "}", "'fx' and 'fy' must be positive"},
      {R"({"fx": 500, "fy": 0, "cx": 320, "cy": 240, )" + size + pose + "}", "'fx' and 'fy' must be positive"},
      {R"({"fx": 500, "fy": 500, "cx": 700, "cy": 240, )" + size + pose + "}", "'cx' must be within 0..width"},
      {"{" + k + R"("width": 640.5, "height": 480, )" + pose + "}", "'width' must be an integer"},
      {"{" + k + R"("width": 640, "height": 5000, )" + pose + "}", "'height' must be 1..4096"},
      {"{" + k + R"("width": 0, "height": 480, )" + pose + "}", "'width' must be 1..4096"},
      {"{" + k + size + R"("pose": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]})", "'pose' must be 4 rows of 4 numbers"},
      {"{" + k + size + R"("pose": [[1,0,0],[0,1,0],[0,0,1],[0,0,0]]})", "'pose' must be 4 rows of 4 numbers"},
      {"{" + k + size + R"("pose": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,1,1]]})", "'pose' last row must be 0 0 0 1"},
      {"{" + k + size + R"("pose": [[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]})", "'pose' rotation is not a rotation"},
      {"{" + k + size + R"("pose": [[-1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]})", "'pose' rotation is not a rotation"},
      {"{" + k + size + R"("pose": [[1,0.01,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]})",
       "'pose' rotation is not a rotation"},
      {"{" + k + size + R"("pose": [[1,0,0,1e7],[0,1,0,0],[0,0,1,0],[0,0,0,1]]})", "'pose' translation beyond 1e6 m"},
      {"{" + k + size + R"("pose": [[1,0,0,"x"],[0,1,0,0],[0,0,1,0],[0,0,0,1]]})", "'pose[0][3]' must be a number"},
      {"{" + k + size + pose + ", " + std::string(20000, ' ') + "}", "JSON over 16384 bytes"},
  };
  for (const Bad& b : cases) {
    auto c = parse_camera_json(b.json, kMaxViewSize);
    ASSERT_FALSE(c) << b.json;
    EXPECT_EQ(c.error().code, ErrorCode::kInvalidArgument);
    EXPECT_NE(c.error().message.find(b.message), std::string::npos)
        << "expected \"" << b.message << "\" in: " << c.error().message;
    EXPECT_EQ(c.error().message.find('\n'), std::string::npos);
  }
  // JSON has no NaN or Infinity literals; a number too large for a double is rejected by the parser as well.
  EXPECT_FALSE(parse_camera_json(R"({"fx": NaN})", kMaxViewSize));
  auto huge =
      parse_camera_json("{" + k + size + R"("pose": [[1,0,0,1e999],[0,1,0,0],[0,0,1,0],[0,0,0,1]]})", kMaxViewSize);
  EXPECT_FALSE(huge);
  // A float-printed rotation (7 digits) is within the tolerance.
  EXPECT_TRUE(parse_camera_json("{" + k + size + R"("pose": [[0.8660254,0,0.5,0],[0,1,0,0],[-0.5,0,0.8660254,0],
      [0,0,0,1]]})",
                                kMaxViewSize));
}

TEST(CameraJson, IsTheViewRoutesCameraParameter) {
  auto r = parse_view_request({{"camera", kValid}, {"format", "png"}});
  ASSERT_TRUE(r) << r.error().message;
  ASSERT_TRUE(r->full_camera);
  EXPECT_EQ(r->width, 640);
  EXPECT_EQ(r->format, ImageFormat::kPng);
  auto cam = make_view_camera(*r, {});
  ASSERT_TRUE(cam);
  EXPECT_EQ(cam->fx, 517.3);
  EXPECT_EQ(cam->camera_to_world(0, 3), 0.1);
  auto both = parse_view_request({{"camera", kValid}, {"pose", "capture"}});
  ASSERT_FALSE(both);
  EXPECT_EQ(both.error().message, "parameter 'camera': a full camera excludes pose");
  auto sized = parse_view_request({{"camera", kValid}, {"width", "100"}});
  ASSERT_FALSE(sized);
  auto bad = parse_view_request({{"camera", "{}"}});
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().message, "parameter 'camera': missing 'fx'");
}

}  // namespace
}  // namespace rgbdcast::service
