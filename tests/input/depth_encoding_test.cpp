// Dataset formats made in the test: a SUN3D-style 3x3 intrinsics text file, NYU Depth v2 disparity PGMs and SUN's
// bit-rotated millimetre PNGs, each checked by the metres it decodes to.
#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "input/depth_encoding.h"
#include "input/frame_source.h"
#include "input/intrinsics_io.h"
#include "tests/common/test_data.h"

namespace rgbdcast {
namespace {

constexpr int kW = 64, kH = 48;

std::uint16_t sun_encode(std::uint16_t mm) { return static_cast<std::uint16_t>((mm << 3) | (mm >> 13)); }

// A frame on disk: a grey colour PNG and `depth` (16-bit) under `depth_name`.
class DatasetFrame : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = test::temp_dir("depth_encoding"); }
  std::string color_path() const { return dir_ + "/color.png"; }
  std::string write(const cv::Mat& depth, const std::string& depth_name) {
    cv::imwrite(color_path(), cv::Mat(depth.size(), CV_8UC3, cv::Scalar(90, 120, 150)));
    const std::string path = dir_ + "/" + depth_name;
    EXPECT_TRUE(cv::imwrite(path, depth));
    return path;
  }
  std::string write_text(const std::string& name, const std::string& text) {
    std::ofstream(dir_ + "/" + name) << text;
    return dir_ + "/" + name;
  }
  // A camera for the small test images (the presets are 640x480).
  std::string camera() { return write_text("camera-intrinsics.txt", "50 0 31.5\n0 52 23.5\n0 0 1\n"); }
  Result<RgbdFrame> load(const std::string& depth_path, DepthEncoding encoding, const std::string& intrinsics = "",
                         std::optional<double> depth_scale = std::nullopt) {
    SourceOptions o;
    o.depth_path = depth_path;
    o.depth_encoding = encoding;
    o.intrinsics = intrinsics;
    o.depth_scale = depth_scale;
    auto src = open_frame_source(color_path(), o);
    if (!src) return src.error();
    return (*src)->frame(0);
  }
  std::string dir_;
};

void expect_one_line_error(const Result<RgbdFrame>& r, const std::string& needle) {
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput) << r.error().message;
  EXPECT_NE(r.error().message.find(needle), std::string::npos) << r.error().message;
  EXPECT_EQ(r.error().message.find('\n'), std::string::npos);
}

TEST(IntrinsicsText, ReadsASun3dCameraMatrix) {
  auto k = parse_intrinsics_matrix_text("570.3422 0 320\n0 570.3422 240\n0 0 1\n", "camera-intrinsics.txt");
  ASSERT_TRUE(k) << k.error().message;
  EXPECT_DOUBLE_EQ(k->fx, 570.3422);
  EXPECT_DOUBLE_EQ(k->fy, 570.3422);
  EXPECT_DOUBLE_EQ(k->cx, 320.0);
  EXPECT_DOUBLE_EQ(k->cy, 240.0);
  EXPECT_EQ(k->width, 0);  // from the images
  EXPECT_DOUBLE_EQ(k->depth_scale, 1000.0);
}

TEST(IntrinsicsText, RefusesWhatIsNotAPinholeMatrix) {
  for (const char* bad : {"570 0 320 0 570 240 0 0", "570 0 320 0 570 240 0 0 1 7", "570 2 320 0 570 240 0 0 1",
                          "570 0 320 0 570 240 0 0 2", "-570 0 320 0 570 240 0 0 1", "570 0 320 0 nan 240 0 0 1",
                          "fx 0 320 0 570 240 0 0 1", ""}) {
    auto k = parse_intrinsics_matrix_text(bad, "k.txt");
    ASSERT_FALSE(k) << bad;
    EXPECT_EQ(k.error().code, ErrorCode::kInvalidInput);
    EXPECT_EQ(k.error().message.rfind("k.txt: ", 0), 0u) << k.error().message;
  }
  EXPECT_FALSE(parse_intrinsics_matrix_text(std::string(kMaxIntrinsicsTextBytes + 1, ' '), "k.txt"));
}

TEST_F(DatasetFrame, AMatrixTextFileTakesItsSizeFromTheImagesAndMillimetres) {
  cv::Mat depth(kH, kW, CV_16UC1, cv::Scalar(1500));
  const std::string d = write(depth, "depth.png");
  const std::string k = camera();
  auto f = load(d, DepthEncoding::kPng16, k);
  ASSERT_TRUE(f) << f.error().message;
  EXPECT_EQ(f->intrinsics.width, kW);
  EXPECT_EQ(f->intrinsics.height, kH);
  EXPECT_DOUBLE_EQ(f->intrinsics.fy, 52.0);
  EXPECT_FLOAT_EQ(f->depth_m.at<float>(10, 10), 1.5f);
  auto scaled = load(d, DepthEncoding::kPng16, k, 5000.0);  // --depth-scale applies
  ASSERT_TRUE(scaled) << scaled.error().message;
  EXPECT_FLOAT_EQ(scaled->depth_m.at<float>(10, 10), 0.3f);
}

TEST_F(DatasetFrame, NyuDisparityPgmDecodesToMetres) {
  cv::Mat raw(kH, kW, CV_16UC1);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) raw.at<std::uint16_t>(y, x) = static_cast<std::uint16_t>(600 + 7 * x);  // 600..1041
  raw.at<std::uint16_t>(5, 5) = 2047;                                                                    // no depth
  raw.at<std::uint16_t>(6, 6) = 1100;  // past 1092.5: no finite positive depth
  auto f = load(write(raw, "depth.pgm"), DepthEncoding::kNyu, camera());
  ASSERT_TRUE(f) << f.error().message;
  EXPECT_NEAR(f->depth_m.at<float>(0, 0), 351.3 / (1092.5 - 600), 1e-5);    // 0.713 m
  EXPECT_NEAR(f->depth_m.at<float>(3, 63), 351.3 / (1092.5 - 1041), 1e-4);  // 6.82 m
  EXPECT_EQ(f->depth_m.at<float>(5, 5), 0.0f);
  EXPECT_EQ(f->depth_m.at<float>(6, 6), 0.0f);
  EXPECT_DOUBLE_EQ(f->intrinsics.depth_scale, 1000.0);  // the source's scale is reported, not nyu's metres
}

TEST_F(DatasetFrame, SunBitRotatedMillimetresDecodeToMetres) {
  cv::Mat raw(kH, kW, CV_16UC1);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) raw.at<std::uint16_t>(y, x) = sun_encode(static_cast<std::uint16_t>(500 + 100 * x));
  raw.at<std::uint16_t>(0, 0) = sun_encode(9000);  // past 8.192 m the rotation carries bits into the low end
  auto f = load(write(raw, "depth.png"), DepthEncoding::kSun, camera(), std::nullopt);
  ASSERT_TRUE(f) << f.error().message;
  EXPECT_FLOAT_EQ(f->depth_m.at<float>(0, 0), 9.0f);
  EXPECT_FLOAT_EQ(f->depth_m.at<float>(1, 0), 0.5f);
  EXPECT_FLOAT_EQ(f->depth_m.at<float>(1, 20), 2.5f);
  EXPECT_FLOAT_EQ(f->depth_m.at<float>(1, 63), 6.8f);
  EXPECT_DOUBLE_EQ(f->intrinsics.depth_scale, 1000.0);
}

TEST_F(DatasetFrame, SunIsMillimetresWhateverThePresetsUnit) {
  cv::Mat raw(480, 640, CV_16UC1, cv::Scalar(sun_encode(1234)));
  auto f = load(write(raw, "depth.png"), DepthEncoding::kSun, "kinect");  // the kinect preset's unit is 5000 a metre
  ASSERT_TRUE(f) << f.error().message;
  EXPECT_FLOAT_EQ(f->depth_m.at<float>(240, 320), 1.234f);
  auto scaled = load(write(raw, "depth.png"), DepthEncoding::kSun, "kinect", 2000.0);  // --depth-scale still wins
  ASSERT_TRUE(scaled) << scaled.error().message;
  EXPECT_FLOAT_EQ(scaled->depth_m.at<float>(240, 320), 0.617f);
}

TEST_F(DatasetFrame, SunDepthReadAsPlainPng16IsRefusedWithAHint) {
  cv::Mat raw(kH, kW, CV_16UC1);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) raw.at<std::uint16_t>(y, x) = sun_encode(static_cast<std::uint16_t>(1500 + 80 * x));
  const std::string d = write(raw, "depth.png");
  expect_one_line_error(load(d, DepthEncoding::kPng16, "", 1000.0), "--depth-encoding sun");
}

TEST_F(DatasetFrame, NyuDisparityReadAsPng16IsRefused) {
  cv::Mat raw(kH, kW, CV_16UC1, cv::Scalar(800));
  raw(cv::Rect(0, 0, kW, 4)).setTo(2047);
  expect_one_line_error(load(write(raw, "depth.pgm"), DepthEncoding::kPng16), "Kinect's disparity");
}

TEST_F(DatasetFrame, MillimetresReadAsNyuAreRefused) {
  cv::Mat raw(kH, kW, CV_16UC1, cv::Scalar(2600));
  expect_one_line_error(load(write(raw, "depth.png"), DepthEncoding::kNyu), "not NYU raw depth");
}

TEST(DepthEncoding, NamesRoundTrip) {
  for (DepthEncoding e : {DepthEncoding::kPng16, DepthEncoding::kNyu, DepthEncoding::kSun})
    EXPECT_EQ(parse_depth_encoding(to_string(e)), e);
  EXPECT_FALSE(parse_depth_encoding("png"));
}

}  // namespace
}  // namespace rgbdcast
