#pragma once
// The keyframe stage over a sequence: for each frame in [from, to], detect features, estimate the motion from the
// last tracked frame (frame-to-frame, as the paper's window assumes small inter-frame motion), chain it into a
// camera-to-world pose in the first tracked frame's coordinates, and decide whether it is a keyframe. A frame that
// cannot be loaded, has no features with depth, has a timestamp not after the last tracked frame's, or has too few
// matches is skipped (its record says why) and the next frame is tried against the same last tracked frame.
// on_keyframe is called for each keyframe, in order, with the frame and its record (pose filled in): the place to
// reduce it and add it to a scene. Its error is noted in the record and processing goes on.
//
// With the input module (input/frame_source.h):
//   auto source = open_frame_source(path, options);                  // Result<unique_ptr<FrameSource>>
//   SequenceParams params;  params.from = N;  params.to = M;  params.odometry.features.type = FeatureType::kOrb;
//   auto result = track_sequence((*source)->size(), [&](size_t i) { return (*source)->frame(i); }, params,
//       [&](const RgbdFrame& f, const FrameRecord& r) -> Status {    // per keyframe: reduce, place at r.pose
//         auto reduced = reduce_frame(f, reduction_params);  if (!reduced) return reduced.error();
//         scene.nodes.push_back({name, reduced->mesh, {}, r.pose});  // + a CaptureCamera at r.pose
//         return ok_status(); },
//       [&](const FrameRecord& r, size_t done, size_t total) { /* progress bar */ });
//   report["frames"] = frames_json(*result);                          // keyframes/sequence_report.h
#include <Eigen/Core>
#include <cstddef>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "keyframes/frame_odometry.h"
#include "keyframes/keyframe_selector.h"
#include "keyframes/trajectory_io.h"

namespace rgbdcast {

struct SequenceParams {
  OdometryParams odometry;
  KeyframeParams keyframes;
  size_t from = 0;                                    // first frame index
  size_t to = std::numeric_limits<size_t>::max();     // last frame index, inclusive (clamped to the source)
  Status validate() const;
};

struct FrameRecord {
  size_t index = 0;
  double timestamp = 0.0;
  int matches = 0;   // windowed matches with the last tracked frame (0 for the first)
  int inliers = 0;   // RANSAC inliers
  bool tracked = false;   // has a pose
  bool keyframe = false;
  bool icp_used = false;
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();  // camera to world (first tracked frame = identity)
  double ms = 0.0;        // load + features + match + RANSAC (+ ICP) for this frame, excluding on_keyframe
  std::string message;    // why it was skipped, or notes (ICP not used, keyframe reason, callback error)
};

struct SequenceResult {
  std::vector<FrameRecord> frames;
  size_t tracked = 0, keyframes = 0, skipped = 0;
  Trajectory trajectory() const;  // the tracked frames' poses (index and timestamp set)
};

using FrameLoader = std::function<Result<RgbdFrame>(size_t index)>;
using KeyframeCallback = std::function<Status(const RgbdFrame& frame, const FrameRecord& record)>;
using ProgressCallback = std::function<void(const FrameRecord& record, size_t done, size_t total)>;

// frame_count: frames in the source (indices 0..frame_count-1). Errors: kInvalidArgument (bad params, empty
// range), kEmpty ("no frame of 12..20 could be tracked": every frame failed; the message gives the first reason).
Result<SequenceResult> track_sequence(size_t frame_count, const FrameLoader& load, const SequenceParams& params,
                                      const KeyframeCallback& on_keyframe = {},
                                      const ProgressCallback& on_progress = {});

}  // namespace rgbdcast
