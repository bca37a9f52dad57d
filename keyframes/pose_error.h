#pragma once
// Relative pose error (Sturm et al. 2012, TUM benchmark): for consecutive estimated poses P_i, P_j and their
// ground-truth poses Q_i, Q_j, E = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j); the error is |translation(E)| in metres and the
// rotation angle of E in degrees. Independent of the two trajectories' world frames.
#include <string>
#include <vector>

#include "keyframes/trajectory_io.h"

namespace rgbdcast {

enum class PoseAssociation {
  kTimestamp,  // ground truth nearest each estimated timestamp (TUM)
  kIndex,      // ground truth with the same frame index (Redwood .log, ICL-NUIM pose.txt)
};

struct RpeParams {
  PoseAssociation association = PoseAssociation::kTimestamp;
  double max_time_difference_s = 0.02;
};

struct RpePair {
  int from_index = -1, to_index = -1;  // estimated poses' indices (or positions when they have none)
  double from_time = 0.0, to_time = 0.0;
  double translation_m = 0.0, rotation_deg = 0.0;
  double gt_translation_m = 0.0, gt_rotation_deg = 0.0;  // the true motion, for scale
};

struct RpeResult {
  std::vector<RpePair> pairs;
  double translation_rmse_m = 0.0, translation_mean_m = 0.0, translation_max_m = 0.0;
  double rotation_rmse_deg = 0.0, rotation_mean_deg = 0.0, rotation_max_deg = 0.0;
  std::vector<std::string> warnings;  // estimated poses without ground truth, out-of-order timestamps
};

// Pairs consecutive poses of `estimated` (in its order). Estimated poses without a ground-truth match are skipped
// with a warning. Errors: kEmpty when no consecutive pair has ground truth for both ends.
Result<RpeResult> relative_pose_error(const Trajectory& estimated, const Trajectory& ground_truth,
                                      const RpeParams& params = {});

}  // namespace rgbdcast
