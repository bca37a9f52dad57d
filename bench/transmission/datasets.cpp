#include "bench/transmission/datasets.h"

#include <Eigen/Geometry>
#include <cstdio>

#include "input/frame_source.h"
#include "keyframes/features.h"
#include "keyframes/frame_odometry.h"
#include "keyframes/trajectory_io.h"

namespace rgbdcast::bench {

namespace {

ReferenceView view_of(const RgbdFrame& frame, const Eigen::Matrix4d& camera_to_sent, const std::string& name) {
  CaptureCamera cam;
  cam.intrinsics = frame.intrinsics;
  cam.camera_to_world = camera_to_sent;
  ReferenceView v;
  v.name = name;
  v.camera = ViewCamera::from_capture(cam);
  v.color_rgb = frame.color_rgb;
  v.valid = frame.depth_m > 0;
  return v;
}

std::string motion_text(const Eigen::Matrix4d& t) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.1f cm, %.2f deg", 100.0 * translation_m(t), rotation_deg(t));
  return buf;
}

// Odometry from the sent frame to frame k (k's camera in the sent frame's camera frame).
Result<PairEstimate> odometry(const RgbdFrame& sent, const RgbdFrame& other) {
  const OdometryParams params;
  auto f0 = detect_features(sent, params.features);
  if (!f0) return f0.error();
  auto fk = detect_features(other, params.features);
  if (!fk) return fk.error();
  return estimate_pair(sent, *f0, other, *fk, params);
}

// Opens the folder and loads frames 0..count-1.
Result<std::vector<RgbdFrame>> load_frames(const std::string& folder, size_t count) {
  auto source = open_frame_source(folder, {});
  if (!source) return source.error();
  std::vector<RgbdFrame> frames;
  for (size_t i = 0; i < count && i < (*source)->size(); ++i) {
    auto f = (*source)->frame(i);
    if (!f) return f.error();
    frames.push_back(std::move(*f));
  }
  if (frames.size() < 2) return make_error(ErrorCode::kInvalidInput, folder + ": fewer than 2 frames");
  return frames;
}

// Frames 0..4 of `folder`, frame 0 sent, novel views at the trajectory's poses of frames 1.. (indexed by
// frame), each checked against the frame odometry (a note; not used for rendering).
template <typename Read>
Result<TestCase> load_indexed_case(const std::string& name, const std::string& folder,
                                   const std::string& trajectory_name, Read&& read) {
  TestCase tc;
  tc.name = name;
  tc.folder = folder;
  auto frames = load_frames(tc.folder, 5);
  if (!frames) return frames.error();
  auto trajectory = read(tc.folder + "/" + trajectory_name);
  if (!trajectory) return trajectory.error();
  const StampedPose* p0 = pose_with_index(*trajectory, 0);
  if (!p0) return make_error(ErrorCode::kNotFound, trajectory_name + " has no frame 0");
  tc.sent = (*frames)[0];
  tc.views.push_back(view_of(tc.sent, Eigen::Matrix4d::Identity(), "capture"));
  for (size_t k = 1; k < frames->size(); ++k) {
    const StampedPose* pk = pose_with_index(*trajectory, static_cast<int>(k));
    if (!pk) return make_error(ErrorCode::kNotFound, trajectory_name + " has no frame " + std::to_string(k));
    const Eigen::Matrix4d rel = p0->camera_to_world.inverse() * pk->camera_to_world;
    tc.views.push_back(view_of((*frames)[k], rel, "frame " + std::to_string(k)));
    std::string note = "frame " + std::to_string(k) + ": ground-truth pose, " + motion_text(rel) + " from frame 0";
    if (auto est = odometry(tc.sent, (*frames)[k]))
      note += "; odometry error " + motion_text(rel.inverse() * est->cur_to_prev);
    else
      note += "; odometry failed: " + est.error().message;
    tc.notes.push_back(note);
  }
  return tc;
}

}  // namespace

Result<TestCase> load_icl_case(const std::string& data_dir) {
  return load_indexed_case("Augmented ICL-NUIM living room (synthetic + simulated Kinect noise)",
                           data_dir + "/augmented_icl_livingroom", "trajectory.log", read_redwood_log);
}

Result<TestCase> load_icl_nuim_case(const std::string& data_dir) {
  return load_indexed_case("ICL-NUIM living room (synthetic, noise-free depth, widely spaced frames)",
                           data_dir + "/icl_nuim_livingroom", "pose.txt",
                           [](const std::string& path) { return read_icl_pose_txt(path); });
}

Result<TestCase> load_tum_case(const std::string& data_dir) {
  TestCase tc;
  tc.name = "TUM RGB-D fr1/xyz (real Kinect)";
  tc.folder = data_dir + "/tum/rgbd_dataset_freiburg1_xyz";
  auto frames = load_frames(tc.folder, 3);
  if (!frames) return frames.error();
  tc.sent = (*frames)[0];
  tc.views.push_back(view_of(tc.sent, Eigen::Matrix4d::Identity(), "capture"));
  // Chained over consecutive frames (how the keyframes module uses the odometry): frame k in frame 0's camera is
  // (k-1 in 0) * (k in k-1).
  Eigen::Matrix4d k_in_sent = Eigen::Matrix4d::Identity();
  for (size_t k = 1; k < frames->size(); ++k) {
    auto est = odometry((*frames)[k - 1], (*frames)[k]);
    if (!est) {
      tc.notes.push_back("frame " + std::to_string(k) + " and later: skipped, odometry failed: " + est.error().message);
      break;
    }
    k_in_sent = k_in_sent * est->cur_to_prev;
    tc.views.push_back(view_of((*frames)[k], k_in_sent, "frame " + std::to_string(k)));
    tc.notes.push_back("frame " + std::to_string(k) + ": ESTIMATED pose (frame odometry " + std::to_string(k - 1) +
                       "->" + std::to_string(k) + ", chained; no ground truth at this timestamp), " +
                       motion_text(k_in_sent) + " from frame 0; this step " + motion_text(est->cur_to_prev) + ", " +
                       std::to_string(est->inliers) + " RANSAC inliers, ICP " +
                       (est->icp_used ? "used" : "not used (" + est->note + ")"));
  }
  return tc;
}

Result<TestCase> load_tum_groundtruth_case(const std::string& data_dir, const std::vector<int>& novel) {
  TestCase tc;
  tc.name = "TUM RGB-D fr1/xyz frames 200-319 (real Kinect, ground truth)";
  tc.folder = data_dir + "/tum/rgbd_dataset_freiburg1_xyz_200_319";
  SourceOptions o;
  o.intrinsics = "fr1";
  auto source = open_frame_source(tc.folder, o);
  if (!source) return source.error();
  auto trajectory = read_tum_trajectory(tc.folder + "/groundtruth.txt");
  if (!trajectory) return trajectory.error();
  auto sent = (*source)->frame(0);
  if (!sent) return sent.error();
  const StampedPose* p0 = nearest_pose(*trajectory, sent->timestamp, 0.02);
  if (!p0) return make_error(ErrorCode::kNotFound, "no ground truth within 0.02 s of frame 0");
  tc.sent = std::move(*sent);
  tc.views.push_back(view_of(tc.sent, Eigen::Matrix4d::Identity(), "capture"));
  for (int k : novel) {
    auto f = (*source)->frame(static_cast<size_t>(k));
    if (!f) return f.error();
    const StampedPose* pk = nearest_pose(*trajectory, f->timestamp, 0.02);
    if (!pk) return make_error(ErrorCode::kNotFound, "no ground truth within 0.02 s of frame " + std::to_string(k));
    const Eigen::Matrix4d rel = p0->camera_to_world.inverse() * pk->camera_to_world;
    tc.views.push_back(view_of(*f, rel, "frame " + std::to_string(k)));
    tc.notes.push_back("frame " + std::to_string(k) + ": ground-truth pose, " + motion_text(rel) + " from frame 0");
  }
  return tc;
}

}  // namespace rgbdcast::bench
