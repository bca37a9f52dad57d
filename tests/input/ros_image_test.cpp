// Decoding of sensor_msgs/Image and CameraInfo fields (input/ros_image.h), on synthetic buffers: no bag needed.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include <fstream>

#include "input/frame_source.h"
#include "input/ros_image.h"
#include "tests/common/test_data.h"

namespace rgbdcast {
namespace {

RosImageView view(const std::string& enc, uint32_t w, uint32_t h, uint32_t step, const std::vector<uint8_t>& d) {
  return {enc, w, h, step, false, d.data(), d.size()};
}

TEST(RosImage, ColourEncodingsGiveTheSameRgbPixels) {
  // 2x1: a red and a blue pixel, with 2 bytes of row padding.
  const std::vector<uint8_t> rgb = {255, 0, 0, 0, 0, 255, 7, 7};
  const std::vector<uint8_t> bgr = {0, 0, 255, 255, 0, 0, 7, 7};
  auto a = ros_color_to_rgb(view("rgb8", 2, 1, 8, rgb), "c");
  auto b = ros_color_to_rgb(view("bgr8", 2, 1, 8, bgr), "c");
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->type(), CV_8UC3);
  EXPECT_EQ(a->at<cv::Vec3b>(0, 0), cv::Vec3b(255, 0, 0));
  EXPECT_EQ(a->at<cv::Vec3b>(0, 1), cv::Vec3b(0, 0, 255));
  EXPECT_EQ(cv::norm(*a, *b, cv::NORM_INF), 0.0);
  auto m = ros_color_to_rgb(view("mono8", 3, 1, 3, {10, 20, 30}), "c");
  ASSERT_TRUE(m);
  EXPECT_EQ(m->at<cv::Vec3b>(0, 2), cv::Vec3b(30, 30, 30));
}

TEST(RosImage, RejectsOtherEncodingsAndShortBuffers) {
  auto e = ros_color_to_rgb(view("yuv422", 2, 1, 4, {1, 2, 3, 4}), "bag:/cam");
  ASSERT_FALSE(e);
  EXPECT_EQ(e.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(e.error().message.find("\"yuv422\""), std::string::npos) << e.error().message;
  EXPECT_NE(e.error().message.find("bag:/cam"), std::string::npos);
  EXPECT_FALSE(ros_color_to_rgb(view("rgb8", 2, 2, 6, std::vector<uint8_t>(11)), "c"));  // 12 bytes needed
  EXPECT_FALSE(ros_color_to_rgb(view("rgb8", 2, 1, 5, std::vector<uint8_t>(6)), "c"));   // step < row
  EXPECT_FALSE(ros_color_to_rgb(view("rgb8", 0, 1, 0, {}), "c"));
  EXPECT_FALSE(ros_color_to_rgb(view("rgb8", 9000, 1, 27000, std::vector<uint8_t>(27000)), "c"));
  auto d = ros_depth(view("32FC3", 1, 1, 12, std::vector<uint8_t>(12)), "d");
  ASSERT_FALSE(d);
  EXPECT_NE(d.error().message.find("16UC1"), std::string::npos);
}

// The bytes of values as a little-endian machine lays them out.
template <class T>
std::vector<uint8_t> bytes_of(std::initializer_list<T> values) {
  std::vector<uint8_t> b(values.size() * sizeof(T));
  std::memcpy(b.data(), values.begin(), b.size());
  return b;
}

TEST(RosImage, DepthKeepsMillimetresAndCleansMetres) {
  const std::vector<uint8_t> b16 = bytes_of<uint16_t>({1234, 0});
  auto d16 = ros_depth(view("16UC1", 2, 1, 4, b16), "d");
  ASSERT_TRUE(d16);
  EXPECT_FALSE(d16->metres);
  EXPECT_EQ(d16->image.at<uint16_t>(0, 0), 1234);
  // Big-endian 1234 = 0x04D2.
  RosImageView be{"16UC1", 1, 1, 2, true, nullptr, 2};
  const std::vector<uint8_t> be_bytes = {0x04, 0xD2};
  be.data = be_bytes.data();
  auto dbe = ros_depth(be, "d");
  ASSERT_TRUE(dbe);
  EXPECT_EQ(dbe->image.at<uint16_t>(0, 0), 1234);

  const std::vector<uint8_t> b32 = bytes_of<float>({1.5f, std::nanf(""), -2.0f, INFINITY});
  auto d32 = ros_depth(view("32FC1", 4, 1, 16, b32), "d");
  ASSERT_TRUE(d32);
  EXPECT_TRUE(d32->metres);
  EXPECT_EQ(d32->image.at<float>(0, 0), 1.5f);
  for (int x = 1; x < 4; ++x) EXPECT_EQ(d32->image.at<float>(0, x), 0.0f) << "no reading becomes 0, x=" << x;
}

RosCameraInfo fr1_info() {
  RosCameraInfo ci;
  ci.width = 640;
  ci.height = 480;
  ci.distortion_model = "plumb_bob";
  ci.D = {0.2624, -0.9531, -0.0054, 0.0026, 1.1633};
  ci.K = {517.3, 0, 318.6, 0, 516.5, 255.3, 0, 0, 1};
  return ci;
}

TEST(RosImage, CameraInfoGivesPinholeAndOpenCvOrderedDistortion) {
  auto k = intrinsics_from_camera_info(fr1_info(), "ci");
  ASSERT_TRUE(k) << k.error().message;
  EXPECT_EQ(k->fx, 517.3);
  EXPECT_EQ(k->fy, 516.5);
  EXPECT_EQ(k->cx, 318.6);
  EXPECT_EQ(k->cy, 255.3);
  EXPECT_EQ(k->width, 640);
  EXPECT_EQ(k->distortion[1], -0.9531);
  EXPECT_EQ(k->distortion[4], 1.1633);
  RosCameraInfo rational = fr1_info();
  rational.distortion_model = "rational_polynomial";
  rational.D.resize(8, 0.0);
  EXPECT_TRUE(intrinsics_from_camera_info(rational, "ci"));
  rational.D[6] = 0.01;
  EXPECT_FALSE(intrinsics_from_camera_info(rational, "ci"));
  RosCameraInfo fisheye = fr1_info();
  fisheye.distortion_model = "equidistant";
  auto e = intrinsics_from_camera_info(fisheye, "ci");
  ASSERT_FALSE(e);
  EXPECT_NE(e.error().message.find("equidistant"), std::string::npos);
  RosCameraInfo none = fr1_info();
  none.D.clear();
  none.distortion_model = "";
  auto p = intrinsics_from_camera_info(none, "ci");
  ASSERT_TRUE(p);
  EXPECT_FALSE(p->has_distortion());
  RosCameraInfo bad = fr1_info();
  bad.K[0] = 0;
  EXPECT_FALSE(intrinsics_from_camera_info(bad, "ci"));
  bad = fr1_info();
  bad.K[4] = NAN;
  EXPECT_FALSE(intrinsics_from_camera_info(bad, "ci"));
  bad = fr1_info();
  bad.width = 0;
  EXPECT_FALSE(intrinsics_from_camera_info(bad, "ci"));
}

// A build without Debian's ROS packages drops the bag tests; this one says so (and fails under CI=true).
TEST(RosbagSupport, IsBuiltIn) {
  const std::string dir = test::temp_dir("bag-support");
  std::ofstream(dir + "/x.bag") << "not a bag";
  auto s = open_frame_source(dir + "/x.bag", {});
  ASSERT_FALSE(s);
  if (s.error().code == ErrorCode::kUnavailable) RGBDCAST_MISSING_PREREQUISITE(s.error().message);
  EXPECT_EQ(s.error().code, ErrorCode::kInvalidInput) << s.error().message;  // read, and found not to be a bag
  EXPECT_NE(s.error().message.find("not a readable ROS 1 bag"), std::string::npos) << s.error().message;
}

}  // namespace
}  // namespace rgbdcast
