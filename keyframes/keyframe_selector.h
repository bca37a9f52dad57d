#pragma once
// Keyframe selection: the first tracked frame is a keyframe; a later frame becomes one when, relative to the last
// keyframe, the camera moved more than max_translation_m or turned more than max_rotation_deg, or the overlap fell
// below min_overlap. Overlap = the fraction of the last keyframe's valid depth points (sampled on a grid) that
// project inside the current image in front of the camera: a frustum overlap, cheap and independent of features.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "input/frame.h"
#include "scene/result.h"

namespace rgbdcast {

struct KeyframeParams {
  double max_translation_m = 0.15;
  double max_rotation_deg = 10.0;
  double min_overlap = 0.7;  // in [0, 1]
  int max_frame_gap = 0;     // force a keyframe after this many frames since the last one; 0 = never
  int overlap_step_px = 8;   // grid step for the overlap sample
  Status validate() const;
};

struct KeyframeDecision {
  bool keyframe = false;
  std::string reason;          // "first", "translation", "rotation", "overlap", "gap", or "" when not a keyframe
  double translation_m = 0.0;  // since the last keyframe
  double rotation_deg = 0.0;
  double overlap = 1.0;
};

class KeyframeSelector {
 public:
  explicit KeyframeSelector(KeyframeParams params = {});
  // Decides for a tracked frame at camera_to_world (frame_index counts frames in the source) and, when it is a
  // keyframe, remembers it as the new reference.
  KeyframeDecision consider(const RgbdFrame& frame, const Eigen::Matrix4d& camera_to_world, int frame_index);
  bool has_keyframe() const { return have_; }

 private:
  KeyframeParams params_;
  bool have_ = false;
  Eigen::Matrix4d kf_to_world_ = Eigen::Matrix4d::Identity();
  int kf_index_ = 0;
  std::vector<Eigen::Vector3d> kf_points_;  // sampled points of the last keyframe, its camera frame
};

// Fraction of points (in frame A's camera) that land inside image (intrinsics) of camera B, given B's pose relative
// to A (a_to_b maps A-points into B). 0 when points is empty.
double view_overlap(const std::vector<Eigen::Vector3d>& points_a, const Eigen::Matrix4d& a_to_b, const Intrinsics& b);

}  // namespace rgbdcast
