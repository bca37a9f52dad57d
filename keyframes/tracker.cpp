#include "keyframes/tracker.h"

#include <Eigen/Geometry>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "base/stopwatch.h"

namespace rgbdcast {

namespace {

std::string fmt(const char* f, double a, double b) {
  char buf[160];
  std::snprintf(buf, sizeof buf, f, a, b);
  return buf;
}

// Rigid motion <-> (rotation vector, translation): enough for a constant-velocity prediction over a few frames.
Eigen::Matrix<double, 6, 1> motion_vector(const Eigen::Matrix4d& t) {
  const Eigen::AngleAxisd aa(Eigen::Matrix3d(t.topLeftCorner<3, 3>()));
  Eigen::Matrix<double, 6, 1> x;
  x.head<3>() = aa.angle() * aa.axis();
  x.tail<3>() = t.topRightCorner<3, 1>();
  return x;
}

Eigen::Matrix4d motion_matrix(const Eigen::Matrix<double, 6, 1>& x) {
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  const double angle = x.head<3>().norm();
  if (angle > 0) t.topLeftCorner<3, 3>() = Eigen::AngleAxisd(angle, x.head<3>() / angle).toRotationMatrix();
  t.topRightCorner<3, 1>() = x.tail<3>();
  return t;
}

// The reference's features with each keypoint moved to where the predicted motion puts it in the current image, so
// that the window matcher searches around the prediction. Points that land behind the camera never match.
FrameFeatures predicted_features(const FrameFeatures& ref, const Eigen::Matrix4d& cur_to_ref, const Intrinsics& k) {
  FrameFeatures moved = ref;  // descriptors shared (cv::Mat header)
  const Eigen::Matrix4d ref_to_cur = cur_to_ref.inverse();
  const Eigen::Matrix3d r = ref_to_cur.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = ref_to_cur.topRightCorner<3, 1>();
  for (size_t i = 0; i < moved.keypoints.size(); ++i) {
    const Eigen::Vector3d p = r * ref.points_m[i] + t;
    if (p.z() < 0.05) {
      moved.keypoints[i].pt = cv::Point2f(-1e6f, -1e6f);
      continue;
    }
    const Eigen::Vector2d px = k.project(p);
    moved.keypoints[i].pt = cv::Point2f(static_cast<float>(px.x()), static_cast<float>(px.y()));
  }
  return moved;
}

}  // namespace

const char* to_string(TrackMethod method) {
  switch (method) {
    case TrackMethod::kNone:
      return "none";
    case TrackMethod::kFirst:
      return "first";
    case TrackMethod::kWindow:
      return "window";
    case TrackMethod::kWide:
      return "wide";
    case TrackMethod::kRelocalised:
      return "relocalised";
  }
  return "?";
}

TrackingParams TrackingParams::paper_window_only() {
  TrackingParams p;
  p.widen = false;
  p.relocalise = false;
  p.reject_implausible = false;
  return p;
}

Status TrackingParams::validate() const {
  if (wide_window_px < 0 || wide_window_px > 10000)
    return make_error(ErrorCode::kInvalidArgument, "tracking: wide window must be in [0, 10000] px");
  if (max_relocalisation_keyframes < 0)
    return make_error(ErrorCode::kInvalidArgument, "tracking: relocalisation keyframes must be >= 0");
  if (min_inliers < 3) return make_error(ErrorCode::kInvalidArgument, "tracking: min_inliers must be >= 3");
  for (double v : {max_icp_rms_m, max_speed_m_s, max_angular_speed_deg_s, frame_interval_s})
    if (!(v > 0) || !std::isfinite(v))
      return make_error(ErrorCode::kInvalidArgument, "tracking: ICP RMS, speed limits and frame interval must be > 0");
  for (double v : {prior_slack_m, prior_slack_deg, max_velocity_change_m_s, max_angular_velocity_change_deg_s})
    if (!(v >= 0) || !std::isfinite(v))
      return make_error(ErrorCode::kInvalidArgument, "tracking: prior slack and velocity change must be >= 0");
  return ok_status();
}

struct Tracker::Attempt {
  PairEstimate pair;
  Eigen::Matrix4d pose;
  int reference;
};

Tracker::Tracker(OdometryParams odometry, TrackingParams tracking, KeyframeParams keyframes)
    : odometry_(std::move(odometry)), tracking_(tracking), selector_(keyframes) {}

double Tracker::seconds_between(const RgbdFrame& a, const RgbdFrame& b) const {
  if (a.timestamp != 0.0 && b.timestamp != 0.0 && b.timestamp > a.timestamp) return b.timestamp - a.timestamp;
  return std::max(1, b.index - a.index) * tracking_.frame_interval_s;
}

Eigen::Matrix4d Tracker::predict_pose(double dt_s) const {
  if (!have_velocity_) return last_->pose;
  return last_->pose * motion_matrix(velocity_ * dt_s);
}

std::optional<Tracker::Attempt> Tracker::try_reference(const View& ref, const RgbdFrame& frame,
                                                       const FrameFeatures& features, const MatchParams& matching,
                                                       bool predict, TrackMethod method,
                                                       const Eigen::Matrix4d& predicted_pose, double dt_s,
                                                       bool have_velocity, std::string* why, int* match_count) {
  const std::string label = std::string(to_string(method)) + " vs " + std::to_string(ref.frame.index) + ": ";
  const Eigen::Matrix4d predicted_cur_to_ref = ref.pose.inverse() * predicted_pose;
  std::vector<FeatureMatch> matches =
      predict ? match_in_window(predicted_features(ref.features, predicted_cur_to_ref, frame.intrinsics), features,
                                matching)
              : match_in_window(ref.features, features, matching);
  if (match_count) *match_count = static_cast<int>(matches.size());
  OdometryParams op = odometry_;
  op.matching = matching;
  Result<PairEstimate> pair = estimate_motion(ref.frame, ref.features, frame, features, matches, op);
  if (!pair) {
    *why += label + pair.error().message + "; ";
    return std::nullopt;
  }
  Attempt a{*pair, ref.pose * pair->cur_to_prev, ref.frame.index};
  if (!pair->note.empty()) *why += label + pair->note + "; ";
  if (!tracking_.reject_implausible) return a;

  auto reject = [&](const std::string& reason) {
    *why += label + "rejected: " + reason + "; ";
    return std::nullopt;
  };
  if (pair->inliers < tracking_.min_inliers)
    return reject(std::to_string(pair->inliers) + " RANSAC inliers (need >= " + std::to_string(tracking_.min_inliers) +
                  ")");
  if (pair->icp_used && pair->icp_rms_m > tracking_.max_icp_rms_m)
    return reject(fmt("ICP residual %.4f m (max %.4f m)", pair->icp_rms_m, tracking_.max_icp_rms_m));
  // Motion since the last tracked frame, against the speed limits and the constant-velocity prediction.
  const Eigen::Matrix4d step = last_->pose.inverse() * a.pose;
  const double step_m = translation_m(step), step_deg = rotation_deg(step);
  if (step_m > tracking_.max_speed_m_s * dt_s + tracking_.prior_slack_m ||
      step_deg > tracking_.max_angular_speed_deg_s * dt_s + tracking_.prior_slack_deg)
    return reject(fmt("a jump of %.3f m / %.1f deg", step_m, step_deg) +
                  fmt(" in %.3f s (faster than %.1f m/s", dt_s, tracking_.max_speed_m_s) +
                  fmt(" or %.0f deg/s)", tracking_.max_angular_speed_deg_s, 0));
  if (have_velocity) {
    const Eigen::Matrix4d off = predicted_pose.inverse() * a.pose;
    const double off_m = translation_m(off), off_deg = rotation_deg(off);
    const double allow_m = tracking_.prior_slack_m + tracking_.max_velocity_change_m_s * dt_s;
    const double allow_deg = tracking_.prior_slack_deg + tracking_.max_angular_velocity_change_deg_s * dt_s;
    if (off_m > allow_m || off_deg > allow_deg)
      return reject(fmt("%.3f m / %.1f deg", off_m, off_deg) +
                    fmt(" from the constant-velocity prediction (allowed %.3f m / %.1f deg)", allow_m, allow_deg));
  }
  return a;
}

TrackStep Tracker::push(const RgbdFrame& frame, KeyframeDecision* keyframe) {
  TrackStep out;
  if (keyframe) *keyframe = KeyframeDecision{};
  auto t0 = std::chrono::steady_clock::now();
  if (last_ && frame.timestamp != 0.0 && last_->frame.timestamp != 0.0 && frame.timestamp <= last_->frame.timestamp) {
    out.failure = "timestamp " + std::to_string(frame.timestamp) + " s is not after the last tracked frame's " +
                  std::to_string(last_->frame.timestamp) + " s (out of order)";
    return out;
  }
  Result<FrameFeatures> features = detect_features(frame, odometry_.features);
  out.features_ms = ms_since(t0);
  if (!features) {
    out.failure = features.error().message;
    return out;
  }
  t0 = std::chrono::steady_clock::now();

  std::optional<Attempt> found;
  if (!last_) {
    out.method = TrackMethod::kFirst;
  } else {
    const double dt = seconds_between(last_->frame, frame);
    const Eigen::Matrix4d predicted = predict_pose(dt);
    std::string why;
    int window_matches = 0;
    // 1. The paper's window around the same pixel of the last tracked frame.
    found = try_reference(*last_, frame, *features, odometry_.matching, false, TrackMethod::kWindow, predicted, dt,
                          have_velocity_, &why, &window_matches);
    if (found) out.method = TrackMethod::kWindow;
    // 2. A wide window around the constant-velocity prediction: the last tracked frame, then the last keyframe.
    if (!found && tracking_.widen) {
      MatchParams wide = odometry_.matching;
      wide.window_px = tracking_.wide_window_px;
      wide.knn = std::max(wide.knn, 16);
      found =
          try_reference(*last_, frame, *features, wide, true, TrackMethod::kWide, predicted, dt, have_velocity_, &why);
      if (!found && !keyframes_.empty() && keyframes_.back().frame.index != last_->frame.index)
        found = try_reference(keyframes_.back(), frame, *features, wide, true, TrackMethod::kWide, predicted, dt,
                              have_velocity_, &why);
      if (found) out.method = TrackMethod::kWide;
    }
    // 3. Earlier keyframes, newest first, without a window. The pose must still be reachable from the last tracked
    // one at hand-held speed, but no velocity is assumed (the motion may have changed during the loss).
    if (!found && tracking_.relocalise) {
      MatchParams global = odometry_.matching;
      global.window_px = 0;
      for (auto it = keyframes_.rbegin(); it != keyframes_.rend() && !found; ++it) {
        if (it->frame.index == last_->frame.index) continue;  // tried above
        found = try_reference(*it, frame, *features, global, false, TrackMethod::kRelocalised, last_->pose, dt, false,
                              &why);
      }
      if (found) out.method = TrackMethod::kRelocalised;
    }
    if (!why.empty()) why.resize(why.size() - 2);
    if (!found) {
      out.failure = why;
      out.matches = window_matches;
      out.match_ms = ms_since(t0);
      return out;
    }
    out.note = why;
    out.reference = found->reference;
    out.matches = found->pair.matches;
    out.inliers = found->pair.inliers;
    out.icp_used = found->pair.icp_used;
    out.icp_rms_m = found->pair.icp_rms_m;
    out.pose = found->pose;
    // Velocity over the time since the last tracked frame.
    velocity_ = motion_vector(last_->pose.inverse() * out.pose) / dt;
    have_velocity_ = true;
  }

  const KeyframeDecision kd = selector_.consider(frame, out.pose, frame.index);
  if (keyframe) *keyframe = kd;
  last_ = View{frame, std::move(*features), out.pose};
  if (kd.keyframe && tracking_.max_relocalisation_keyframes > 0) {
    keyframes_.push_back(*last_);
    while (static_cast<int>(keyframes_.size()) > tracking_.max_relocalisation_keyframes) keyframes_.pop_front();
  }
  out.match_ms = ms_since(t0);
  return out;
}

}  // namespace rgbdcast
