#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>

#include "evaluation/image_metrics.h"

namespace rgbdcast {
namespace {

Image to_rgba(const cv::Mat& rgb, const cv::Mat& covered) {
  Image im = Image::make(rgb.cols, rgb.rows, 4);
  for (int y = 0; y < rgb.rows; ++y)
    for (int x = 0; x < rgb.cols; ++x) {
      const cv::Vec3b c = rgb.at<cv::Vec3b>(y, x);
      std::uint8_t* p = im.pixel(x, y);
      p[0] = c[0], p[1] = c[1], p[2] = c[2], p[3] = covered.at<std::uint8_t>(y, x) ? 255 : 0;
    }
  return im;
}

cv::Mat textured(int w, int h) {
  cv::Mat m(h, w, CV_8UC3);
  cv::randu(m, cv::Scalar::all(40), cv::Scalar::all(215));
  cv::GaussianBlur(m, m, cv::Size(5, 5), 1.0);
  return m;
}

TEST(ImageMetrics, IdenticalViewsArePerfect) {
  cv::Mat ref = textured(64, 48);
  cv::Mat all(48, 64, CV_8U, cv::Scalar(255));
  auto f = compare_views(ref, to_rgba(ref, all), all);
  ASSERT_TRUE(f) << f.error().message;
  EXPECT_DOUBLE_EQ(f->coverage, 1.0);
  EXPECT_GE(f->psnr_db, 99.0);
  EXPECT_NEAR(f->ssim, 1.0, 1e-9);
}

TEST(ImageMetrics, PsnrMatchesKnownNoiseAndCoverageCountsValidPixels) {
  cv::Mat ref(60, 80, CV_8UC3, cv::Scalar(100, 120, 140));
  cv::Mat noisy = ref.clone();
  // +-8 on every channel: MSE = 64, PSNR = 10 log10(255^2 / 64) = 30.07 dB.
  for (int y = 0; y < 60; ++y)
    for (int x = 0; x < 80; ++x) noisy.at<cv::Vec3b>(y, x) += ((x + y) % 2) ? cv::Vec3b(8, 8, 8) : cv::Vec3b(0, 0, 0);
  for (int y = 0; y < 60; ++y)
    for (int x = 0; x < 80; ++x)
      if ((x + y) % 2 == 0) noisy.at<cv::Vec3b>(y, x) -= cv::Vec3b(8, 8, 8);
  cv::Mat valid(60, 80, CV_8U, cv::Scalar(255));
  valid(cv::Rect(0, 0, 80, 10)).setTo(0);  // 50 of 60 rows had depth
  cv::Mat covered(60, 80, CV_8U, cv::Scalar(255));
  covered(cv::Rect(0, 0, 40, 60)).setTo(0);  // the render covers the right half
  auto f = compare_views(ref, to_rgba(noisy, covered), valid);
  ASSERT_TRUE(f) << f.error().message;
  EXPECT_NEAR(f->psnr_db, 10 * std::log10(255.0 * 255.0 / 64.0), 0.01);
  EXPECT_NEAR(f->coverage, 0.5, 1e-9);
  EXPECT_EQ(f->valid_pixels, 50u * 80u);
  EXPECT_LT(f->ssim, 1.0);
}

TEST(ImageMetrics, SsimDropsWithStructureLoss) {
  cv::Mat ref = textured(96, 96);
  cv::Mat blurred;
  cv::GaussianBlur(ref, blurred, cv::Size(9, 9), 3.0);
  cv::Mat all(96, 96, CV_8U, cv::Scalar(255));
  auto sharp = compare_views(ref, to_rgba(ref, all), all);
  auto blur = compare_views(ref, to_rgba(blurred, all), all);
  ASSERT_TRUE(sharp && blur);
  EXPECT_LT(blur->ssim, 0.8 * sharp->ssim);
  EXPECT_LT(blur->psnr_db, 40.0);
}

TEST(ImageMetrics, RejectsMismatchedSizes) {
  cv::Mat ref = textured(64, 48);
  cv::Mat all(48, 64, CV_8U, cv::Scalar(255));
  cv::Mat other = textured(32, 24);
  auto f = compare_views(ref, to_rgba(other, cv::Mat(24, 32, CV_8U, cv::Scalar(255))), all);
  ASSERT_FALSE(f);
  EXPECT_EQ(f.error().code, ErrorCode::kInvalidArgument);
  auto empty = compare_views(ref, to_rgba(ref, all), cv::Mat(48, 64, CV_8U, cv::Scalar(0)));
  ASSERT_FALSE(empty);
  EXPECT_EQ(empty.error().code, ErrorCode::kEmpty);
}

}  // namespace
}  // namespace rgbdcast

namespace rgbdcast {
namespace {

TEST(ImageMetrics, HolesDoNotLowerSsimOfExactPixels) {
  // A render that is exact where it covers, with holes: SSIM over the covered pixels is 1.
  cv::Mat ref = textured(96, 96);
  cv::Mat covered(96, 96, CV_8U, cv::Scalar(255));
  for (int y = 0; y < 96; y += 7)
    for (int x = 0; x < 96; x += 5) covered.at<std::uint8_t>(y, x) = 0;
  cv::Mat all(96, 96, CV_8U, cv::Scalar(255));
  auto f = compare_views(ref, to_rgba(ref, covered), all);
  ASSERT_TRUE(f);
  EXPECT_NEAR(f->ssim, 1.0, 1e-9);
  EXPECT_LT(f->coverage, 1.0);
  // What the operator sees has the holes: lower on every valid-pixel measure.
  EXPECT_LT(f->ssim_valid, 0.99);
  EXPECT_LT(f->psnr_valid_db, 40.0);
}

}  // namespace
}  // namespace rgbdcast
