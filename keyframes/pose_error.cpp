#include "keyframes/pose_error.h"

#include <algorithm>
#include <cmath>

#include "keyframes/frame_odometry.h"

namespace rgbdcast {

Result<RpeResult> relative_pose_error(const Trajectory& est, const Trajectory& gt, const RpeParams& params) {
  RpeResult out;
  struct Matched {
    const StampedPose* e;
    const StampedPose* g;
    int index;
  };
  std::vector<Matched> matched;
  for (size_t i = 0; i < est.poses.size(); ++i) {
    const StampedPose& e = est.poses[i];
    const int index = e.index >= 0 ? e.index : static_cast<int>(i);
    if (i > 0 && params.association == PoseAssociation::kTimestamp && e.timestamp <= est.poses[i - 1].timestamp)
      out.warnings.push_back("estimated pose " + std::to_string(index) + ": timestamp " + std::to_string(e.timestamp) +
                             " not after the previous one");
    const StampedPose* g = params.association == PoseAssociation::kTimestamp
                               ? nearest_pose(gt, e.timestamp, params.max_time_difference_s)
                               : pose_with_index(gt, index);
    if (!g) {
      out.warnings.push_back(
          "estimated pose " + std::to_string(index) + " has no ground truth" +
          (params.association == PoseAssociation::kTimestamp
               ? " within " + std::to_string(params.max_time_difference_s) + " s of t=" + std::to_string(e.timestamp)
               : std::string(" with that index")));
      continue;
    }
    matched.push_back({&e, g, index});
  }
  for (size_t i = 1; i < matched.size(); ++i) {
    const Matched& a = matched[i - 1];
    const Matched& b = matched[i];
    const Eigen::Matrix4d de = a.e->camera_to_world.inverse() * b.e->camera_to_world;
    const Eigen::Matrix4d dg = a.g->camera_to_world.inverse() * b.g->camera_to_world;
    const Eigen::Matrix4d err = dg.inverse() * de;
    RpePair p;
    p.from_index = a.index;
    p.to_index = b.index;
    p.from_time = a.e->timestamp;
    p.to_time = b.e->timestamp;
    p.translation_m = translation_m(err);
    p.rotation_deg = rotation_deg(err);
    p.gt_translation_m = translation_m(dg);
    p.gt_rotation_deg = rotation_deg(dg);
    out.pairs.push_back(p);
  }
  if (out.pairs.empty())
    return make_error(ErrorCode::kEmpty, "relative pose error: no two consecutive estimated poses with ground truth (" +
                                             std::to_string(matched.size()) + " of " +
                                             std::to_string(est.poses.size()) + " poses matched)");
  double st = 0, sr = 0, at = 0, ar = 0;
  for (const RpePair& p : out.pairs) {
    st += p.translation_m * p.translation_m;
    sr += p.rotation_deg * p.rotation_deg;
    at += p.translation_m;
    ar += p.rotation_deg;
    out.translation_max_m = std::max(out.translation_max_m, p.translation_m);
    out.rotation_max_deg = std::max(out.rotation_max_deg, p.rotation_deg);
  }
  const double n = static_cast<double>(out.pairs.size());
  out.translation_rmse_m = std::sqrt(st / n);
  out.rotation_rmse_deg = std::sqrt(sr / n);
  out.translation_mean_m = at / n;
  out.rotation_mean_deg = ar / n;
  return out;
}

}  // namespace rgbdcast
