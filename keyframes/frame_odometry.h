#pragma once
// The motion between two consecutive frames: windowed matches of their features -> RANSAC rigid transform on the
// matched 3D points -> optional point-to-plane ICP on the frames' depth. Fewer than min_matches (paper: N <= 4 is
// too few) surviving matches is a failure whose message says how many survived the window; the caller skips the
// frame and tries the next one against the same previous frame.
#include <Eigen/Core>
#include <string>

#include "keyframes/features.h"
#include "keyframes/icp_refine.h"
#include "keyframes/rigid_ransac.h"
#include "keyframes/window_matcher.h"

namespace rgbdcast {

struct OdometryParams {
  FeatureParams features;
  MatchParams matching;
  RansacParams ransac;
  int min_matches = 5;     // paper: frames with N <= 4 matches are skipped
  bool refine_icp = true;  // point-to-plane ICP after RANSAC (features alone give ~1-2 cm on noisy depth)
  IcpParams icp;
  // ICP is discarded (the RANSAC estimate kept) when it moves the estimate by more than this: ICP slid away.
  double icp_max_correction_m = 0.05;
  double icp_max_correction_deg = 5.0;
  Status validate() const;
};

struct PairEstimate {
  Eigen::Matrix4d cur_to_prev = Eigen::Matrix4d::Identity();  // maps current camera points into the previous camera
  int matches = 0;                                            // surviving the window (and ratio) filter
  int inliers = 0;                                            // RANSAC inliers
  double ransac_rms_m = 0.0;
  bool icp_used = false;
  double icp_rms_m = 0.0;
  std::string note;  // why ICP was not used, when it was asked for
  double match_ms = 0.0, ransac_ms = 0.0, icp_ms = 0.0;
};

// Errors: kEmpty with a message such as "3 matches inside the 20x20 px window (need >= 5)" or RANSAC's failure.
Result<PairEstimate> estimate_pair(const RgbdFrame& prev, const FrameFeatures& prev_features, const RgbdFrame& cur,
                                   const FrameFeatures& cur_features, const OdometryParams& params);
// The same from matches already found (match_in_window(prev_features, cur_features, params.matching)), for callers
// that record the match count even when the motion fails.
Result<PairEstimate> estimate_motion(const RgbdFrame& prev, const FrameFeatures& prev_features, const RgbdFrame& cur,
                                     const FrameFeatures& cur_features, const std::vector<FeatureMatch>& matches,
                                     const OdometryParams& params);

// Translation (m) and rotation angle (deg) of a rigid 4x4 transform.
double translation_m(const Eigen::Matrix4d& t);
double rotation_deg(const Eigen::Matrix4d& t);

}  // namespace rgbdcast
