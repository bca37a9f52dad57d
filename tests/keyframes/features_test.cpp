// Feature detection on a real frame and on frames where it must fail cleanly.
#include <gtest/gtest.h>

#include "keyframes/features.h"
#include "tests/common/test_data.h"
#include "tests/keyframes/test_frames.h"

namespace rgbdcast {
namespace {

TEST(Features, EveryKeypointHasDepthOnRealFrame) {
  REQUIRE_DATA("augmented_icl_livingroom/color/00000.jpg");
  const test::TestSequence seq = test::augmented_icl_sequence();
  Result<RgbdFrame> f = seq.loader()(0);
  ASSERT_TRUE(f) << f.error().message;
  for (FeatureType t : {FeatureType::kSift, FeatureType::kOrb, FeatureType::kAkaze}) {
    FeatureParams p;
    p.type = t;
    Result<FrameFeatures> ff = detect_features(*f, p);
    ASSERT_TRUE(ff) << ff.error().message;
    std::printf("%s: %d detected, %zu with depth\n", to_string(t), ff->detected, ff->size());
    EXPECT_GT(ff->size(), 100u);
    EXPECT_LE(static_cast<int>(ff->size()), ff->detected);
    EXPECT_EQ(ff->descriptors.rows, static_cast<int>(ff->size()));
    EXPECT_EQ(ff->descriptors.type(), is_binary_descriptor(t) ? CV_8U : CV_32F);
    for (size_t i = 0; i < ff->size(); ++i) {
      const cv::Point2f pt = ff->keypoints[i].pt;
      const float z = f->depth_m.at<float>(static_cast<int>(std::lround(pt.y)), static_cast<int>(std::lround(pt.x)));
      ASSERT_GT(z, 0.f);
      EXPECT_NEAR(ff->points_m[i].z(), z, 1e-6);
    }
  }
}

TEST(Features, ZeroDepthKeypointsAreDropped) {
  REQUIRE_DATA("augmented_icl_livingroom/color/00000.jpg");
  Result<RgbdFrame> f = test::augmented_icl_sequence().loader()(0);
  ASSERT_TRUE(f);
  Result<FrameFeatures> full = detect_features(*f, FeatureParams{});
  ASSERT_TRUE(full);
  // Remove the depth of the left half: no surviving keypoint may lie there.
  f->depth_m(cv::Rect(0, 0, f->depth_m.cols / 2, f->depth_m.rows)).setTo(0.f);
  Result<FrameFeatures> half = detect_features(*f, FeatureParams{});
  ASSERT_TRUE(half);
  EXPECT_EQ(half->detected, full->detected);
  EXPECT_LT(half->size(), full->size());
  for (const cv::KeyPoint& k : half->keypoints) EXPECT_GE(std::lround(k.pt.x), f->depth_m.cols / 2 - 1);
  // No depth at all: a clear error that still says how many keypoints the detector found.
  f->depth_m.setTo(0.f);
  Result<FrameFeatures> none = detect_features(*f, FeatureParams{});
  ASSERT_FALSE(none);
  EXPECT_EQ(none.error().code, ErrorCode::kEmpty);
  EXPECT_NE(none.error().message.find(std::to_string(full->detected) + " detected"), std::string::npos)
      << none.error().message;
}

TEST(Features, BlankImageAndBadTypesGiveErrors) {
  RgbdFrame f;
  f.color_rgb = cv::Mat(480, 640, CV_8UC3, cv::Scalar(90, 90, 90));
  f.depth_m = cv::Mat(480, 640, CV_32F, cv::Scalar(1.5f));
  for (FeatureType t : {FeatureType::kSift, FeatureType::kOrb, FeatureType::kAkaze}) {
    FeatureParams p;
    p.type = t;
    Result<FrameFeatures> r = detect_features(f, p);
    ASSERT_FALSE(r) << to_string(t);
    EXPECT_EQ(r.error().code, ErrorCode::kEmpty);
    EXPECT_NE(r.error().message.find("0 detected"), std::string::npos) << r.error().message;
  }
  RgbdFrame wrong = f;
  wrong.depth_m = cv::Mat(240, 320, CV_32F, cv::Scalar(1.0f));
  EXPECT_EQ(detect_features(wrong, FeatureParams{}).error().code, ErrorCode::kInvalidInput);
  wrong = f;
  wrong.color_rgb = cv::Mat(480, 640, CV_8UC1, cv::Scalar(0));
  EXPECT_EQ(detect_features(wrong, FeatureParams{}).error().code, ErrorCode::kInvalidInput);
  EXPECT_EQ(detect_features(RgbdFrame{}, FeatureParams{}).error().code, ErrorCode::kInvalidInput);
  FeatureParams bad;
  bad.smoothing_sigma_px = -1;
  EXPECT_EQ(detect_features(f, bad).error().code, ErrorCode::kInvalidArgument);
  EXPECT_TRUE(parse_feature_type("ORB"));
  EXPECT_FALSE(parse_feature_type("surf"));
}

}  // namespace
}  // namespace rgbdcast
