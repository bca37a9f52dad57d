#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "input/frame_source.h"
#include "input/intrinsics_io.h"
#include "tests/common/test_data.h"

namespace fs = std::filesystem;

namespace rgbdcast {
namespace {

const char* kFr1 = "tum/rgbd_dataset_freiburg1_xyz";

TEST(FrameSource, OpensTumFr1XyzWithItsPresetAndUndistorts) {
  REQUIRE_DATA(kFr1);
  auto src = open_frame_source(test::data_path(kFr1), {});
  ASSERT_TRUE(src) << src.error().message;
  EXPECT_EQ((*src)->kind(), "tum");
  EXPECT_EQ((*src)->size(), 3u);  // the 4th rgb image has no depth within 0.02 s
  EXPECT_EQ((*src)->intrinsics().name, "fr1");
  auto f = (*src)->frame(0);
  ASSERT_TRUE(f) << f.error().message;
  EXPECT_EQ(f->color_rgb.type(), CV_8UC3);
  EXPECT_EQ(f->depth_m.type(), CV_32FC1);
  EXPECT_FALSE(f->intrinsics.has_distortion());
  EXPECT_NEAR(f->timestamp, 1305031102.175304, 1e-6);
  double lo = 1e9, hi = 0;
  for (int v = 0; v < f->depth_m.rows; ++v)
    for (int u = 0; u < f->depth_m.cols; ++u) {
      const float z = f->depth_m.at<float>(v, u);
      if (z > 0) lo = std::min<double>(lo, z), hi = std::max<double>(hi, z);
    }
  // The data's README: valid depth runs 0.86-3.7 m.
  EXPECT_GT(lo, 0.5);
  EXPECT_LT(hi, 4.5);
  const double valid = cv::countNonZero(f->depth_m) / 307200.0;
  EXPECT_GT(valid, 0.70);
  EXPECT_LT(valid, 0.80);
}

TEST(FrameSource, UndistortionMovesADistortedDotToItsPinholePosition) {
  Intrinsics k = *intrinsics_preset("fr1");
  // A 3D point seen through the real (distorted) lens lands at `distorted`; after undistortion the frame must show
  // it where the ideal pinhole projects it.
  const Eigen::Vector3d p(0.45, -0.30, 1.0);
  cv::Mat K = (cv::Mat_<double>(3, 3) << k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
  cv::Mat D(1, 5, CV_64F);
  for (int i = 0; i < 5; ++i) D.at<double>(i) = k.distortion[i];
  std::vector<cv::Point2d> distorted;
  cv::projectPoints(std::vector<cv::Point3d>{{p.x(), p.y(), p.z()}}, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D,
                    distorted);
  const Eigen::Vector2d ideal = k.project(p);
  ASSERT_GT((Eigen::Vector2d(distorted[0].x, distorted[0].y) - ideal).norm(), 3.0) << "lens must move this point";

  cv::Mat color(480, 640, CV_8UC3, cv::Scalar(0, 0, 0));
  cv::circle(color, cv::Point(int(std::lround(distorted[0].x)), int(std::lround(distorted[0].y))), 3,
             cv::Scalar(255, 255, 255), cv::FILLED);
  cv::Mat depth(480, 640, CV_16UC1, cv::Scalar(5000));
  auto f = make_frame(color, depth, k);
  ASSERT_TRUE(f) << f.error().message;
  cv::Mat grey;
  cv::cvtColor(f->color_rgb, grey, cv::COLOR_RGB2GRAY);
  cv::Moments m = cv::moments(grey > 128, true);
  ASSERT_GT(m.m00, 5);
  const Eigen::Vector2d found(m.m10 / m.m00, m.m01 / m.m00);
  EXPECT_LT((found - ideal).norm(), 1.0) << "found " << found.transpose() << " expected " << ideal.transpose();
}

TEST(FrameSource, ReadsAnOrganizedPcd) {
  REQUIRE_DATA("pcl_kinect_organized/pcd/frame_20121214T142255.814212.pcd");
  auto src = open_frame_source(test::data_path("pcl_kinect_organized/pcd/frame_20121214T142255.814212.pcd"), {});
  ASSERT_TRUE(src) << src.error().message;
  auto f = (*src)->frame(0);
  ASSERT_TRUE(f) << f.error().message;
  EXPECT_EQ(f->xyz_m.size(), cv::Size(640, 480));
  const double valid = cv::countNonZero(f->depth_m) / 307200.0;
  EXPECT_GT(valid, 0.80);  // the data's README: about 88 % valid
  EXPECT_LT(valid, 0.95);
  EXPECT_FALSE((*src)->frame(1));
}

TEST(FrameSource, OpensTheRedwoodLayoutWithItsCameraJson) {
  REQUIRE_DATA("augmented_icl_livingroom");
  auto src = open_frame_source(test::data_path("augmented_icl_livingroom"), {});
  ASSERT_TRUE(src) << src.error().message;
  EXPECT_EQ((*src)->kind(), "redwood");
  EXPECT_EQ((*src)->size(), 5u);
  EXPECT_DOUBLE_EQ((*src)->intrinsics().depth_scale, 1000.0);
  EXPECT_DOUBLE_EQ((*src)->intrinsics().fx, 525.0);
  auto f = (*src)->frame(4);
  ASSERT_TRUE(f) << f.error().message;
  EXPECT_NE(f->color_path.find("00004.jpg"), std::string::npos);
}

TEST(FrameSource, OpensAPngPair) {
  REQUIRE_DATA("tum/freiburg2_desk_pair/1.png");
  SourceOptions o;
  o.intrinsics = "fr2";
  o.depth_path = test::data_path("tum/freiburg2_desk_pair/1_depth.png");
  auto src = open_frame_source(test::data_path("tum/freiburg2_desk_pair/1.png"), o);
  ASSERT_TRUE(src) << src.error().message;
  auto f = (*src)->frame(0);
  ASSERT_TRUE(f) << f.error().message;
  EXPECT_GT(cv::countNonZero(f->depth_m), 100000);
}

// ---- bad input: each a clear one-line error of the right kind

void expect_one_line_error(const Result<RgbdFrame>& r, ErrorCode code, const std::string& needle) {
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, code) << r.error().message;
  EXPECT_NE(r.error().message.find(needle), std::string::npos) << r.error().message;
  EXPECT_EQ(r.error().message.find('\n'), std::string::npos);
}

class BadInput : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = test::temp_dir("badinput"); }
  std::string write_pair(const cv::Mat& color, const cv::Mat& depth) {
    cv::imwrite(dir_ + "/c.png", color);
    cv::imwrite(dir_ + "/d.png", depth);
    return dir_ + "/c.png";
  }
  Result<RgbdFrame> load(const std::string& color) {
    SourceOptions o;
    o.depth_path = dir_ + "/d.png";
    auto src = open_frame_source(color, o);
    if (!src) return src.error();
    return (*src)->frame(0);
  }
  std::string dir_;
};

TEST_F(BadInput, MissingFile) {
  auto src = open_frame_source(dir_ + "/nope.png", {});
  ASSERT_FALSE(src);
  EXPECT_EQ(src.error().code, ErrorCode::kNotFound);
}

TEST_F(BadInput, CorruptPng) {
  write_pair(cv::Mat(480, 640, CV_8UC3, cv::Scalar(9, 9, 9)), cv::Mat(480, 640, CV_16UC1, cv::Scalar(5000)));
  std::ofstream(dir_ + "/c.png", std::ios::binary | std::ios::trunc) << "\x89PNG\r\n\x1a\n garbage";
  expect_one_line_error(load(dir_ + "/c.png"), ErrorCode::kInvalidInput, "not a readable image");
}

TEST_F(BadInput, TruncatedPng) {
  write_pair(cv::Mat(480, 640, CV_8UC3, cv::Scalar(9, 9, 9)), cv::Mat(480, 640, CV_16UC1, cv::Scalar(5000)));
  const auto size = fs::file_size(dir_ + "/d.png");
  fs::resize_file(dir_ + "/d.png", size / 3);
  auto r = load(dir_ + "/c.png");
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput) << r.error().message;
}

TEST_F(BadInput, DepthThatIsNot16Bit) {
  write_pair(cv::Mat(480, 640, CV_8UC3, cv::Scalar(9, 9, 9)), cv::Mat(480, 640, CV_8UC1, cv::Scalar(50)));
  expect_one_line_error(load(dir_ + "/c.png"), ErrorCode::kInvalidInput, "16-bit");
}

TEST_F(BadInput, ColourAndDepthOfDifferentSizes) {
  write_pair(cv::Mat(480, 640, CV_8UC3, cv::Scalar(9, 9, 9)), cv::Mat(240, 320, CV_16UC1, cv::Scalar(5000)));
  expect_one_line_error(load(dir_ + "/c.png"), ErrorCode::kInvalidInput, "different sizes");
}

TEST_F(BadInput, ImagesOfAnotherSizeThanTheIntrinsics) {
  write_pair(cv::Mat(240, 320, CV_8UC3, cv::Scalar(9, 9, 9)), cv::Mat(240, 320, CV_16UC1, cv::Scalar(5000)));
  expect_one_line_error(load(dir_ + "/c.png"), ErrorCode::kInvalidInput, "intrinsics");
}

TEST_F(BadInput, AllZeroDepth) {
  write_pair(cv::Mat(480, 640, CV_8UC3, cv::Scalar(9, 9, 9)), cv::Mat(480, 640, CV_16UC1, cv::Scalar(0)));
  expect_one_line_error(load(dir_ + "/c.png"), ErrorCode::kEmpty, "no valid depth");
}

TEST_F(BadInput, FramePastTheEnd) {
  REQUIRE_DATA(kFr1);
  auto src = open_frame_source(test::data_path(kFr1), {});
  ASSERT_TRUE(src);
  expect_one_line_error((*src)->frame(3), ErrorCode::kNotFound, "past the end");
}

TEST_F(BadInput, FolderThatIsNoKnownLayout) {
  auto src = open_frame_source(dir_, {});
  ASSERT_FALSE(src);
  EXPECT_EQ(src.error().code, ErrorCode::kInvalidInput);
}

TEST_F(BadInput, CorruptPcd) {
  std::ofstream(dir_ + "/x.pcd") << "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                                    "WIDTH 640\nHEIGHT 480\nPOINTS 307200\nDATA binary\n\x01\x02";
  auto src = open_frame_source(dir_ + "/x.pcd", {});
  ASSERT_TRUE(src);
  auto f = (*src)->frame(0);
  ASSERT_FALSE(f);
  EXPECT_EQ(f.error().code, ErrorCode::kInvalidInput) << f.error().message;
}

}  // namespace
}  // namespace rgbdcast
