// Query parsing of GET /v1/scenes/{id}/view: every malformed, missing, non-finite or out-of-range parameter is a
// kInvalidArgument (HTTP 400) naming the parameter; good queries give the numbers they say.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "service/view_params.h"

using rgbdcast::ErrorCode;
using rgbdcast::RenderMode;
using namespace rgbdcast::service;

namespace {
QueryParams q(std::initializer_list<std::pair<const std::string, std::string>> items) { return QueryParams(items); }

void expect_bad(const QueryParams& params, const std::string& mentions) {
  auto r = parse_view_request(params);
  ASSERT_FALSE(r.ok()) << "accepted a bad query that should mention " << mentions;
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(r.error().message.find(mentions), std::string::npos) << r.error().message;
}
}  // namespace

TEST(ServiceViewParams, CapturePoseWithDefaults) {
  auto r = parse_view_request(q({{"pose", "capture"}}));
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_TRUE(r->capture_pose);
  EXPECT_EQ(r->width, 640);
  EXPECT_EQ(r->height, 480);
  EXPECT_EQ(r->mode, RenderMode::kMesh);
  EXPECT_EQ(r->format, ImageFormat::kJpeg);
}

TEST(ServiceViewParams, LookAtWithEverything) {
  auto r = parse_view_request(q({{"eye", "0.5,-0.25,1e-1"},
                                 {"target", "0,0,2"},
                                 {"up", "0,-1,0"},
                                 {"fov", "60"},
                                 {"width", "4096"},
                                 {"height", "1"},
                                 {"mode", "points"},
                                 {"format", "png"},
                                 {"quality", "100"},
                                 {"point_size", "3"}}));
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_FALSE(r->capture_pose);
  EXPECT_DOUBLE_EQ(r->eye.x(), 0.5);
  EXPECT_DOUBLE_EQ(r->eye.y(), -0.25);
  EXPECT_DOUBLE_EQ(r->eye.z(), 0.1);
  EXPECT_DOUBLE_EQ(r->target.z(), 2.0);
  EXPECT_DOUBLE_EQ(r->fov_deg, 60.0);
  EXPECT_EQ(r->width, 4096);
  EXPECT_EQ(r->height, 1);
  EXPECT_EQ(r->mode, RenderMode::kPoints);
  EXPECT_EQ(r->format, ImageFormat::kPng);
  EXPECT_EQ(r->quality, 100);
  EXPECT_FLOAT_EQ(r->point_size_px, 3.0f);
}

TEST(ServiceViewParams, MissingOrContradictoryPose) {
  expect_bad(q({}), "missing the pose");
  expect_bad(q({{"width", "100"}}), "missing the pose");
  expect_bad(q({{"eye", "0,0,0"}}), "target");
  expect_bad(q({{"target", "0,0,1"}}), "eye");
  expect_bad(q({{"pose", "capture"}, {"eye", "0,0,0"}, {"target", "0,0,1"}}), "pose");
  expect_bad(q({{"pose", "robot"}}), "pose");
  expect_bad(q({{"fov", "40"}}), "fov");
  expect_bad(q({{"eye", "1,1,1"}, {"target", "1,1,1"}}), "equals eye");
}

TEST(ServiceViewParams, NonFiniteNumbersAreRejected) {
  for (const char* bad : {"nan,0,0", "0,inf,0", "0,0,-inf", "NaN,0,0", "0,0,infinity", "1e999,0,0"})
    expect_bad(q({{"eye", bad}, {"target", "0,0,1"}}), "eye");
  expect_bad(q({{"eye", "0,0,0"}, {"target", "0,0,1"}, {"fov", "nan"}}), "fov");
  expect_bad(q({{"eye", "0,0,0"}, {"target", "0,0,1"}, {"fov", "inf"}}), "fov");
}

TEST(ServiceViewParams, MalformedNumbers) {
  for (const char* bad : {"", "1,2", "1,2,3,4", "a,b,c", "1,,3", " 1,2,3", "1,2,3 ", "+1,2,3", "0x1,2,3", "1;2;3"})
    expect_bad(q({{"eye", bad}, {"target", "0,0,1"}}), "eye");
  expect_bad(q({{"pose", "capture"}, {"width", "12px"}}), "width");
  expect_bad(q({{"pose", "capture"}, {"width", "1.5"}}), "width");
  expect_bad(q({{"pose", "capture"}, {"height", ""}}), "height");
  expect_bad(q({{"pose", "capture"}, {"width", "99999999999999999999"}}), "width");
}

TEST(ServiceViewParams, SizesAndRanges) {
  expect_bad(q({{"pose", "capture"}, {"width", "0"}}), "width");
  expect_bad(q({{"pose", "capture"}, {"width", "5000"}}), "width");
  expect_bad(q({{"pose", "capture"}, {"height", "4097"}}), "height");
  expect_bad(q({{"pose", "capture"}, {"height", "-1"}}), "height");
  expect_bad(q({{"pose", "capture"}, {"quality", "0"}}), "quality");
  expect_bad(q({{"pose", "capture"}, {"quality", "101"}}), "quality");
  expect_bad(q({{"eye", "0,0,0"}, {"target", "0,0,1"}, {"fov", "180"}}), "fov");
  expect_bad(q({{"eye", "0,0,0"}, {"target", "0,0,1"}, {"up", "0,0,0"}}), "up");
  expect_bad(q({{"pose", "capture"}, {"point_size", "0"}}), "point_size");
  EXPECT_TRUE(parse_view_request(q({{"pose", "capture"}, {"width", "1"}, {"height", "4096"}})).ok());
}

TEST(ServiceViewParams, UnknownRepeatedAndBadEnums) {
  expect_bad(q({{"pose", "capture"}, {"zoom", "2"}}), "unknown parameter");
  expect_bad(q({{"pose", "capture"}, {"width", "100"}, {"width", "200"}}), "more than once");
  expect_bad(q({{"pose", "capture"}, {"mode", "wireframe"}}), "mode");
  expect_bad(q({{"pose", "capture"}, {"format", "gif"}}), "format");
}

TEST(ServiceViewParams, CameraFromRequest) {
  rgbdcast::CaptureCamera cam;
  cam.intrinsics.fx = 517.3;
  cam.intrinsics.fy = 516.5;
  cam.intrinsics.cx = 318.6;
  cam.intrinsics.cy = 255.3;
  auto r = parse_view_request(q({{"pose", "capture"}, {"width", "320"}, {"height", "240"}}));
  ASSERT_TRUE(r.ok());
  auto c = make_view_camera(*r, {cam});
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_NEAR(c->fx, 517.3 / 2, 1e-9);  // half the size, half the focal length
  EXPECT_EQ(c->width, 320);
  // Up parallel to the view direction is caught when the camera is made.
  auto r2 = parse_view_request(q({{"eye", "0,0,0"}, {"target", "0,-1,0"}}));
  ASSERT_TRUE(r2.ok());
  auto c2 = make_view_camera(*r2, {cam});
  ASSERT_FALSE(c2.ok());
  EXPECT_EQ(c2.error().code, ErrorCode::kInvalidArgument);
}

// fov: 179 degrees is the documented maximum (scene/camera.h, openapi.yaml, --fov). It parses and makes a camera
// with the focal length a pinhole has there, fy = h / 2 / tan(89.5 deg); anything past it is refused.
TEST(ServiceViewParams, FovUpTo179Degrees) {
  auto r = parse_view_request(q({{"eye", "0,0,0"}, {"target", "0,0,1"}, {"fov", "179"}, {"height", "480"}}));
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_DOUBLE_EQ(r->fov_deg, 179.0);
  auto c = make_view_camera(*r, {});
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_NEAR(c->fy, 240.0 / std::tan(89.5 * M_PI / 180.0), 1e-9);
  EXPECT_GT(c->fy, 2.0);  // 2.09 px: finite, positive
  expect_bad(q({{"eye", "0,0,0"}, {"target", "0,0,1"}, {"fov", "179.01"}}), "between 1 and 179 degrees");
  EXPECT_FALSE(rgbdcast::ViewCamera::look_at({0, 0, 0}, {0, 0, 1}, {0, -1, 0}, 179.01, 64, 48).ok());
}

// What a client sent is quoted in at most 40 bytes, one printable line: a name or value holding a decoded %0A (or
// any control character, DEL, a backslash, UTF-8 bytes) comes back as \xNN, never as a second line.
TEST(ServiceViewParams, ErrorsAreOnePrintableLine) {
  auto printable_line = [](const std::string& message) {
    for (unsigned char c : message)
      if (c < 0x20 || c >= 0x7f) return false;
    return true;
  };
  const std::string hostile = std::string("a\nb\r\x1b[31m\x7f") + "\xc3\xa9\\" + std::string(1, '\0') + "z";
  const QueryParams cases[] = {
      q({{"pose", "capture"}, {hostile, "1"}}),                      // unknown name
      q({{"pose", "capture"}, {"mode", hostile}}),                   // bad enum
      q({{"pose", "capture"}, {"width", hostile}}),                  // bad integer
      q({{"eye", hostile}, {"target", "0,0,1"}}),                    // bad vector
      q({{"eye", "0,0,0"}, {"target", "0,0,1"}, {"fov", hostile}}),  // bad number
      q({{"camera", nlohmann::json{{"fx", 1},
                                   {"fy", 1},
                                   {"cx", 0},
                                   {"cy", 0},
                                   {"width", 1},
                                   {"height", 1},
                                   {"pose", nlohmann::json::array()},
                                   {hostile, 1}}
                        .dump()}}),  // unknown camera key
  };
  for (const auto& params : cases) {
    auto r = parse_view_request(params);
    ASSERT_FALSE(r.ok());
    EXPECT_TRUE(printable_line(r.error().message)) << r.error().message;
    EXPECT_NE(r.error().message.find("a\\x0ab\\x0d\\x1b[31m\\x7f\\xc3\\xa9\\x5c\\x00z"), std::string::npos)
        << r.error().message;
  }
  // Long input is cut at 40 bytes.
  auto r = parse_view_request(q({{"pose", "capture"}, {"mode", std::string(1000, 'm')}}));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find(std::string(40, 'm') + "..."), std::string::npos);
  EXPECT_EQ(r.error().message.find(std::string(41, 'm')), std::string::npos);
}
