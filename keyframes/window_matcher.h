#pragma once
// Descriptor matching between consecutive frames (paper section 4): FLANN (a KD-tree for SIFT's float descriptors,
// LSH for binary ORB/AKAZE descriptors) finds each current keypoint's nearest descriptors in the previous frame;
// only a candidate whose keypoint lies inside a window of window_px x window_px around the current keypoint's
// position (|du|, |dv| <= window_px / 2) may be its match. The paper uses 20 x 20.
#include <vector>

#include "keyframes/features.h"

namespace rgbdcast {

struct MatchParams {
  int window_px = 20;      // full window edge; 0 = no window (global matching, for comparison)
  int knn = 8;             // FLANN neighbours examined per keypoint (the window filter picks among them)
  double ratio = 0.8;      // Lowe's ratio between the best and second-best candidate inside the window; 1 = off
  bool one_to_one = true;  // a previous keypoint keeps only its best current match
  // false (the paper's order): FLANN's knn nearest descriptors, then the window picks among them, so a true match
  // outside the knn is lost. true: every previous keypoint inside the window is compared by brute force (an x-sorted
  // sweep, cv::hal distances; cv::BFMatcher when there is no window): exact, and cheaper than building a FLANN
  // index per frame, since a 20 px window holds a few dozen keypoints.
  bool exact_window = false;
  Status validate() const;
};

struct FeatureMatch {
  int prev = -1;         // index into the previous frame's FrameFeatures
  int cur = -1;          // index into the current frame's FrameFeatures
  float distance = 0.f;  // descriptor distance (L2 for SIFT, Hamming for binary)
};

// True when b lies inside the window of edge window_px centred on a (window_px <= 0: always true).
bool inside_window(const cv::Point2f& a, const cv::Point2f& b, int window_px);

// Matches cur against prev. Returns an empty list when either side has no descriptors or their kinds differ.
std::vector<FeatureMatch> match_in_window(const FrameFeatures& prev, const FrameFeatures& cur,
                                          const MatchParams& params);

}  // namespace rgbdcast
