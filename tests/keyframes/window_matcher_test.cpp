// The 20 x 20 window of the matcher, on synthetic features where the descriptor-nearest keypoint is placed
// inside or outside the window, for float (KD-tree) and binary (LSH) descriptors.
#include <gtest/gtest.h>

#include <random>

#include "keyframes/window_matcher.h"

namespace rgbdcast {
namespace {

// n keypoints on a grid 40 px apart with random descriptors; cur = prev shifted by (dx, dy) with the same
// descriptors (plus a little noise for float ones).
void make_pair(FeatureType type, int n, float dx, float dy, FrameFeatures* prev, FrameFeatures* cur) {
  std::mt19937 rng(5);
  prev->type = cur->type = type;
  const bool binary = is_binary_descriptor(type);
  prev->descriptors.create(n, binary ? 32 : 128, binary ? CV_8U : CV_32F);
  if (binary)
    cv::randu(prev->descriptors, 0, 256);
  else
    cv::randu(prev->descriptors, 0.f, 1.f);
  cur->descriptors = prev->descriptors.clone();
  if (!binary) {
    cv::Mat noise(cur->descriptors.size(), CV_32F);
    cv::randn(noise, 0.f, 0.01f);
    cur->descriptors += noise;
  }
  for (int i = 0; i < n; ++i) {
    const cv::Point2f p(20.f + 40.f * static_cast<float>(i % 15), 20.f + 40.f * static_cast<float>(i / 15));
    prev->keypoints.emplace_back(p, 5.f);
    cur->keypoints.emplace_back(p + cv::Point2f(dx, dy), 5.f);
    prev->points_m.emplace_back(0, 0, 1);
    cur->points_m.emplace_back(0, 0, 1);
  }
}

TEST(WindowMatcher, InsideWindowIsPlusMinusHalfTheEdge) {
  const cv::Point2f a(100, 100);
  EXPECT_TRUE(inside_window(a, {110, 90}, 20));
  EXPECT_FALSE(inside_window(a, {110.5f, 100}, 20));
  EXPECT_FALSE(inside_window(a, {100, 89.5f}, 20));
  EXPECT_TRUE(inside_window(a, {500, 500}, 0));  // 0 = no window
}

// Both searches: FLANN's nearest descriptors then the window (the paper's order), and the exact sweep over the
// keypoints inside the window (exact_window, cv::BFMatcher when there is no window).
TEST(WindowMatcher, RejectsMatchesOutside20x20) {
  for (bool exact : {false, true})
    for (FeatureType type : {FeatureType::kSift, FeatureType::kOrb}) {
      SCOPED_TRACE(std::string(to_string(type)) + (exact ? " exact" : " flann"));
      MatchParams params;  // 20 x 20
      params.exact_window = exact;
      {
        FrameFeatures prev, cur;
        make_pair(type, 150, 6.f, -7.f, &prev, &cur);  // inside
        const std::vector<FeatureMatch> m = match_in_window(prev, cur, params);
        EXPECT_GE(m.size(), 145u);
        for (const FeatureMatch& x : m) EXPECT_EQ(x.prev, x.cur);
      }
      {
        FrameFeatures prev, cur;
        make_pair(type, 150, 14.f, 0.f, &prev, &cur);  // the true partner 14 px away: outside +-10
        EXPECT_TRUE(match_in_window(prev, cur, params).empty());
        MatchParams wide = params;
        wide.window_px = 30;
        EXPECT_GE(match_in_window(prev, cur, wide).size(), 145u);
        MatchParams global = params;
        global.window_px = 0;
        EXPECT_GE(match_in_window(prev, cur, global).size(), 145u);
      }
      {
        FrameFeatures prev, cur;
        make_pair(type, 150, 0.f, -10.5f, &prev, &cur);  // just outside in v
        EXPECT_TRUE(match_in_window(prev, cur, params).empty());
      }
    }
}

// A wrong partner inside the window is taken only when the right one is outside it: the window decides which
// candidates exist, the descriptor distance which of them wins.
TEST(WindowMatcher, PrefersNearestDescriptorInsideWindow) {
  FrameFeatures prev, cur;
  make_pair(FeatureType::kSift, 2, 0.f, 0.f, &prev, &cur);
  // prev keypoint 0 at (20,20), keypoint 1 at (60,20). Current keypoint 0 at (25,20) with descriptor of prev 1.
  cur.keypoints[0].pt = {25, 20};
  prev.descriptors.row(1).copyTo(cur.descriptors.row(0));
  cur.keypoints[1].pt = {400, 400};
  for (bool exact : {false, true}) {
    MatchParams p;
    p.ratio = 1.0;
    p.exact_window = exact;
    const std::vector<FeatureMatch> m = match_in_window(prev, cur, p);
    ASSERT_EQ(m.size(), 1u) << exact;
    EXPECT_EQ(m[0].cur, 0);
    EXPECT_EQ(m[0].prev, 0);  // prev 1 has the better descriptor but lies 35 px away
  }
}

TEST(WindowMatcher, EmptyOrMismatchedInputGivesNoMatches) {
  FrameFeatures a, b, c;
  make_pair(FeatureType::kSift, 10, 0, 0, &a, &b);
  EXPECT_TRUE(match_in_window(a, FrameFeatures{}, MatchParams{}).empty());
  FrameFeatures orb1, orb2;
  make_pair(FeatureType::kOrb, 10, 0, 0, &orb1, &orb2);
  EXPECT_TRUE(match_in_window(a, orb2, MatchParams{}).empty());  // float vs binary
  MatchParams bad;
  bad.knn = 0;
  EXPECT_FALSE(bad.validate());
}

}  // namespace
}  // namespace rgbdcast
