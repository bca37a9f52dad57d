#pragma once
// Incremental camera tracking, one frame at a time (what track_sequence and a live sender both run). Each frame is
// tried in order of cost, and the first plausible result is kept:
//   1. "window": the paper's match (features inside a 20x20 px window around the same pixel in the last tracked
//      frame), RANSAC, ICP;
//   2. "wide": the last tracked frame, then the last keyframe, matched inside a wide window around where a
//      constant-velocity prediction puts each of their keypoints, RANSAC, ICP;
//   3. "relocalised": earlier keyframes, newest first, matched without a window (ratio test only), RANSAC, ICP.
// A result is implausible, and rejected rather than chained, when it has too few RANSAC inliers, an ICP residual
// too high for Kinect depth, or a pose further from the constant-velocity prediction (or a speed higher) than
// hand-held motion allows over the time since the last tracked frame. A frame nothing explains is skipped: its
// record lists why each try failed, and the next frame is tried against the same last tracked frame.
//
// Not thread-safe; one Tracker per camera. Frames (cv::Mat headers, shared pixels) are kept for the last tracked
// frame and up to max_relocalisation_keyframes keyframes; the caller must not write into a pushed frame's images.
#include <Eigen/Core>
#include <deque>
#include <optional>
#include <string>

#include "keyframes/frame_odometry.h"
#include "keyframes/keyframe_selector.h"

namespace rgbdcast {

// How a frame's pose was found (kNone: skipped).
enum class TrackMethod { kNone, kFirst, kWindow, kWide, kRelocalised };
const char* to_string(TrackMethod method);  // "none", "first", "window", "wide", "relocalised"

struct TrackingParams {
  bool widen = true;               // try "wide" when the window fails
  bool relocalise = true;          // try earlier keyframes when "wide" fails
  bool reject_implausible = true;  // the plausibility gates below; false = chain whatever RANSAC/ICP returns (paper)
  int wide_window_px = 160;        // window edge around the predicted keypoint position; 0 = no window
  int max_relocalisation_keyframes = 8;  // earlier keyframes kept for relocalisation (newest first)
  // Plausibility gates.
  int min_inliers = 15;          // RANSAC inliers
  double max_icp_rms_m = 0.012;  // point-to-plane RMS of the refinement (Kinect noise at 1-2 m is 3-6 mm)
  double max_speed_m_s = 2.0;    // hand-held camera: translation / time since the last tracked frame
  double max_angular_speed_deg_s = 180.0;
  // Deviation allowed from the constant-velocity prediction: slack + change * dt (dt = time since the last tracked
  // frame). 2 cm / 2 deg covers the estimates' own noise; 1 m/s and 90 deg/s of velocity change per second of gap
  // cover a hand-held camera's acceleration.
  double prior_slack_m = 0.02, prior_slack_deg = 2.0;
  double max_velocity_change_m_s = 1.0, max_angular_velocity_change_deg_s = 90.0;
  double frame_interval_s = 1.0 / 30.0;  // dt per frame index when frames have no timestamps
  // The paper's method alone: the window, nothing else, nothing rejected (for comparison).
  static TrackingParams paper_window_only();
  Status validate() const;
};

struct TrackStep {
  TrackMethod method = TrackMethod::kNone;
  int reference = -1;            // frame index the pose was estimated against (-1 for the first frame)
  int matches = 0, inliers = 0;  // of the try that was kept; for a skipped frame, the window's matches
  bool icp_used = false;
  double icp_rms_m = 0.0;
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();  // camera to world
  double features_ms = 0.0, match_ms = 0.0;            // features; everything after them (match, RANSAC, ICP, checks)
  std::string note;                                    // why earlier tries failed, ICP notes
  std::string failure;                                 // why the frame was skipped (empty when tracked)
  bool tracked() const { return method != TrackMethod::kNone; }
};

class Tracker {
 public:
  Tracker(OdometryParams odometry, TrackingParams tracking, KeyframeParams keyframes);
  // Tracks a frame (frame.index set by the caller). Errors are not returned: a frame that cannot be tracked comes
  // back with method kNone and `failure` set. `keyframe` is the selector's decision (false for skipped frames).
  TrackStep push(const RgbdFrame& frame, KeyframeDecision* keyframe = nullptr);
  bool has_pose() const { return last_.has_value(); }

 private:
  struct View {
    RgbdFrame frame;
    FrameFeatures features;
    Eigen::Matrix4d pose;  // camera to world
  };
  struct Attempt;
  std::optional<Attempt> try_reference(const View& ref, const RgbdFrame& frame, const FrameFeatures& features,
                                       const MatchParams& matching, bool predict, TrackMethod method,
                                       const Eigen::Matrix4d& predicted_pose, double dt_s, bool have_velocity,
                                       std::string* why, int* match_count = nullptr);
  double seconds_between(const RgbdFrame& a, const RgbdFrame& b) const;
  Eigen::Matrix4d predict_pose(double dt_s) const;

  OdometryParams odometry_;
  TrackingParams tracking_;
  KeyframeSelector selector_;
  std::optional<View> last_;
  std::deque<View> keyframes_;  // newest at the back
  bool have_velocity_ = false;
  Eigen::Matrix<double, 6, 1> velocity_ = Eigen::Matrix<double, 6, 1>::Zero();  // (rotation vector, translation)/s
};

}  // namespace rgbdcast
