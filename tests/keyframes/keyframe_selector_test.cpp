// Keyframe decisions from poses: motion thresholds and frustum overlap.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "keyframes/keyframe_selector.h"

namespace rgbdcast {
namespace {

RgbdFrame flat_frame(float z) {
  RgbdFrame f;
  f.color_rgb = cv::Mat(480, 640, CV_8UC3, cv::Scalar(0, 0, 0));
  f.depth_m = cv::Mat(480, 640, CV_32F, cv::Scalar(z));
  return f;
}

Eigen::Matrix4d pose(double tx, double yaw_deg) {
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  t.topLeftCorner<3, 3>() = Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  t(0, 3) = tx;
  return t;
}

TEST(KeyframeSelector, MotionThresholds) {
  KeyframeParams p;
  p.max_translation_m = 0.1;
  p.max_rotation_deg = 5.0;
  p.min_overlap = 0.0;
  KeyframeSelector s(p);
  const RgbdFrame f = flat_frame(2.0f);
  EXPECT_EQ(s.consider(f, pose(0, 0), 0).reason, "first");
  EXPECT_FALSE(s.consider(f, pose(0.05, 0), 1).keyframe);
  const KeyframeDecision d = s.consider(f, pose(0.12, 0), 2);
  EXPECT_TRUE(d.keyframe);
  EXPECT_EQ(d.reason, "translation");
  EXPECT_NEAR(d.translation_m, 0.12, 1e-12);
  EXPECT_FALSE(s.consider(f, pose(0.15, 2), 3).keyframe);  // measured from the new keyframe at 0.12
  EXPECT_EQ(s.consider(f, pose(0.12, 6), 4).reason, "rotation");
}

TEST(KeyframeSelector, OverlapOfAPlane) {
  // A plane 2 m away filling the image; a sideways move of d shifts it by fx * d / z pixels: 0.4 m -> 105 px of
  // 640 -> about 84 % overlap; 1 m -> 262 px -> about 59 %.
  const Intrinsics k;
  std::vector<Eigen::Vector3d> pts;
  for (int v = 4; v < 480; v += 8)
    for (int u = 4; u < 640; u += 8) pts.push_back(k.backproject(u, v, 2.0));
  auto overlap_after = [&](double dx) {
    Eigen::Matrix4d a_to_b = Eigen::Matrix4d::Identity();
    a_to_b(0, 3) = -dx;  // camera B is dx to the right of A
    return view_overlap(pts, a_to_b, k);
  };
  EXPECT_DOUBLE_EQ(overlap_after(0.0), 1.0);
  EXPECT_NEAR(overlap_after(0.4), 1.0 - 105.0 / 640.0, 0.02);
  EXPECT_NEAR(overlap_after(1.0), 1.0 - 262.5 / 640.0, 0.02);

  KeyframeParams p;
  p.max_translation_m = 10.0;
  p.min_overlap = 0.7;
  KeyframeSelector s(p);
  const RgbdFrame f = flat_frame(2.0f);
  s.consider(f, pose(0, 0), 0);
  EXPECT_FALSE(s.consider(f, pose(0.4, 0), 1).keyframe);
  const KeyframeDecision d = s.consider(f, pose(1.0, 0), 2);
  EXPECT_EQ(d.reason, "overlap");
  EXPECT_NEAR(d.overlap, 1.0 - 262.5 / 640.0, 0.02);
}

TEST(KeyframeSelector, FrameGapAndValidation) {
  KeyframeParams p;
  p.max_frame_gap = 3;
  KeyframeSelector s(p);
  const RgbdFrame f = flat_frame(2.0f);
  s.consider(f, pose(0, 0), 0);
  EXPECT_FALSE(s.consider(f, pose(0, 0), 2).keyframe);
  EXPECT_EQ(s.consider(f, pose(0, 0), 3).reason, "gap");
  KeyframeParams bad;
  bad.min_overlap = 1.5;
  EXPECT_FALSE(bad.validate());
}

}  // namespace
}  // namespace rgbdcast
