// rgbdcast eval-trajectory: relative pose error (translation m, rotation deg) of estimated poses against ground
// truth, between consecutive estimated poses. Formats: TUM (t tx ty tz qx qy qz qw), Redwood/Open3D .log, ICL-NUIM
// pose.txt.
#include <iostream>

#include "app/cli_error.h"
#include "app/commands.h"
#include "keyframes/pose_error.h"
#include "keyframes/sequence_report.h"
#include "keyframes/trajectory_io.h"

namespace rgbdcast::app {

void register_eval_trajectory(CLI::App& app) {
  struct Args {
    std::string estimated, ground_truth, match = "auto";
    double max_dt = 0.02;
  };
  auto a = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand("eval-trajectory", "Relative pose error of a trajectory against ground truth");
  cmd->add_option("--estimated", a->estimated, "Estimated trajectory (e.g. from reduce --sequence --trajectory)")
      ->required();
  cmd->add_option("--groundtruth", a->ground_truth, "Ground truth: TUM groundtruth.txt, .log or pose.txt")->required();
  cmd->add_option("--match", a->match, "auto|timestamp|index (auto: index when both have frame indices)")
      ->capture_default_str();
  cmd->add_option("--max-time-difference", a->max_dt, "Timestamp matching tolerance in seconds")->capture_default_str();
  cmd->callback([a] {
    auto fail = [](const Error& e) { app::fail("eval-trajectory", e); };
    auto est = read_trajectory(a->estimated);
    if (!est) fail(est.error());
    auto gt = read_trajectory(a->ground_truth);
    if (!gt) fail(gt.error());
    RpeParams p;
    p.max_time_difference_s = a->max_dt;
    if (a->match == "index")
      p.association = PoseAssociation::kIndex;
    else if (a->match == "timestamp")
      p.association = PoseAssociation::kTimestamp;
    else if (a->match == "auto") {
      const bool indexed =
          !est->poses.empty() && est->poses.front().index >= 0 && !gt->poses.empty() && gt->poses.front().index >= 0;
      p.association = indexed ? PoseAssociation::kIndex : PoseAssociation::kTimestamp;
    } else {
      fail(make_error(ErrorCode::kInvalidArgument, "--match must be auto, timestamp or index"));
    }
    auto rpe = relative_pose_error(*est, *gt, p);
    if (!rpe) fail(rpe.error());
    std::cout << rpe_json(*rpe).dump(2) << "\n";
  });
}

}  // namespace rgbdcast::app
