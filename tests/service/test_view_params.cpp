// Query parsing of GET /v1/scenes/{id}/view: every malformed, missing, non-finite or out-of-range parameter is a
// kInvalidArgument (HTTP 400) naming the parameter; good queries give the numbers they say.
#include <gtest/gtest.h>

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
  auto r = parse_view_request(q({{"eye", "0.5,-0.25,1e-1"}, {"target", "0,0,2"}, {"up", "0,-1,0"}, {"fov", "60"},
                                 {"width", "4096"}, {"height", "1"}, {"mode", "points"}, {"format", "png"},
                                 {"quality", "100"}, {"point_size", "3"}}));
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
