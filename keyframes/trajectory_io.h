#pragma once
// Camera trajectories on disk. Every pose is camera-to-world, with the camera frame in rgbdcast's convention
// (x right, y down, z forward):
// - TUM groundtruth.txt: "t tx ty tz qx qy qz qw" lines, '#' comments. Sorted by time on reading (out-of-order
//   stamps give a warning, duplicates are dropped with a warning).
// - Redwood/Open3D trajectory.log: per frame a line "i j n" (i = frame index) then 4 lines of a 4x4 matrix.
// - ICL-NUIM pose.txt: "tx ty tz qx qy qz qw" per frame (line k = frame k). ICL-NUIM's camera has y UP (its
//   intrinsics have fy = -480): a pixel row v maps to y = (v - cy) / fy * z with fy < 0. In rgbdcast's y-down camera
//   (fy = +480 on the same image) a point is S p with S = diag(1, -1, 1), so the pose becomes S T S: the camera
//   frame and, to keep a proper rotation, the world's y axis are mirrored. Relative motions are exactly conjugated
//   by S, so the relative pose error is the same as ICL's own convention would give.
#include <Eigen/Core>
#include <string>
#include <string_view>
#include <vector>

#include "scene/result.h"

namespace rgbdcast {

struct StampedPose {
  double timestamp = 0.0;  // seconds; 0 when the format has none
  int index = -1;          // frame index; -1 when the format has none (TUM)
  Eigen::Matrix4d camera_to_world = Eigen::Matrix4d::Identity();
};

struct Trajectory {
  std::vector<StampedPose> poses;
  std::vector<std::string> warnings;  // one line each: skipped lines, reordering, duplicates
};

// Errors: kNotFound (missing file), kInvalidInput (no valid pose, or a malformed .log block: the message gives the
// line number). Bad single lines in TUM/ICL files are skipped with a warning; non-unit quaternions are normalised.
Result<Trajectory> read_tum_trajectory(const std::string& path);
Result<Trajectory> read_redwood_log(const std::string& path);
// icl_to_rgbdcast = false keeps ICL's y-up camera (for comparing with tools that use fy < 0).
Result<Trajectory> read_icl_pose_txt(const std::string& path, bool icl_to_rgbdcast = true);
// The same parsers on text in memory (untrusted: any bytes give a Trajectory or a one-line kInvalidInput error);
// `name` stands for the path in messages.
enum class TrajectoryFormat { kTum, kRedwood, kIcl };
Result<Trajectory> parse_trajectory(std::string_view text, TrajectoryFormat format,
                                    const std::string& name = "trajectory");
// By name and content: *.log -> Redwood, 7 numbers per line -> ICL-NUIM, 8 -> TUM.
Result<Trajectory> read_trajectory(const std::string& path);

// Writers (base/atomic_file.h: temp file, fsync, rename). TUM needs timestamps; Redwood uses index (or position
// when index < 0).
Status write_tum_trajectory(const std::string& path, const Trajectory& trajectory);
Status write_redwood_log(const std::string& path, const Trajectory& trajectory);

// The pose whose timestamp is nearest t, or nullptr when none lies within max_difference_s (poses sorted by time).
const StampedPose* nearest_pose(const Trajectory& trajectory, double t, double max_difference_s);
// The pose with this frame index, or nullptr.
const StampedPose* pose_with_index(const Trajectory& trajectory, int index);

// 4x4 from translation and unit quaternion (qx qy qz qw, normalised here), and back.
Eigen::Matrix4d pose_from_tum(double tx, double ty, double tz, double qx, double qy, double qz, double qw);

}  // namespace rgbdcast
