#include "keyframes/keyframe_selector.h"

#include <cmath>

#include "keyframes/frame_odometry.h"

namespace rgbdcast {

Status KeyframeParams::validate() const {
  if (!(max_translation_m > 0) || !(max_rotation_deg > 0))
    return make_error(ErrorCode::kInvalidArgument, "keyframe motion thresholds must be > 0");
  if (!(min_overlap >= 0 && min_overlap <= 1))
    return make_error(ErrorCode::kInvalidArgument, "min_overlap must be in [0, 1]");
  if (max_frame_gap < 0 || overlap_step_px < 1)
    return make_error(ErrorCode::kInvalidArgument, "max_frame_gap must be >= 0 and overlap_step_px >= 1");
  return ok_status();
}

KeyframeSelector::KeyframeSelector(KeyframeParams params) : params_(params) {}

double view_overlap(const std::vector<Eigen::Vector3d>& pts, const Eigen::Matrix4d& a_to_b, const Intrinsics& k) {
  if (pts.empty()) return 0.0;
  const Eigen::Matrix3d r = a_to_b.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = a_to_b.topRightCorner<3, 1>();
  size_t inside = 0;
  for (const Eigen::Vector3d& p : pts) {
    const Eigen::Vector3d q = r * p + t;
    if (q.z() <= 0) continue;
    const Eigen::Vector2d px = k.project(q);
    if (px.x() >= -0.5 && px.y() >= -0.5 && px.x() < k.width - 0.5 && px.y() < k.height - 0.5) ++inside;
  }
  return static_cast<double>(inside) / static_cast<double>(pts.size());
}

KeyframeDecision KeyframeSelector::consider(const RgbdFrame& frame, const Eigen::Matrix4d& camera_to_world, int index) {
  KeyframeDecision d;
  if (!have_) {
    d.keyframe = true;
    d.reason = "first";
  } else {
    const Eigen::Matrix4d kf_to_cur = camera_to_world.inverse() * kf_to_world_;
    d.translation_m = translation_m(kf_to_cur);
    d.rotation_deg = rotation_deg(kf_to_cur);
    d.overlap = view_overlap(kf_points_, kf_to_cur, frame.intrinsics);
    if (d.translation_m > params_.max_translation_m)
      d.reason = "translation";
    else if (d.rotation_deg > params_.max_rotation_deg)
      d.reason = "rotation";
    else if (d.overlap < params_.min_overlap)
      d.reason = "overlap";
    else if (params_.max_frame_gap > 0 && index - kf_index_ >= params_.max_frame_gap)
      d.reason = "gap";
    d.keyframe = !d.reason.empty();
  }
  if (d.keyframe) {
    have_ = true;
    kf_to_world_ = camera_to_world;
    kf_index_ = index;
    kf_points_.clear();
    const Intrinsics& k = frame.intrinsics;
    for (int v = params_.overlap_step_px / 2; v < frame.depth_m.rows; v += params_.overlap_step_px)
      for (int u = params_.overlap_step_px / 2; u < frame.depth_m.cols; u += params_.overlap_step_px) {
        const float z = frame.depth_m.at<float>(v, u);
        if (std::isfinite(z) && z > 0) kf_points_.push_back(k.backproject(u, v, z));
      }
  }
  return d;
}

}  // namespace rgbdcast
