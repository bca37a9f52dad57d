#pragma once
// The keyframe stage over a sequence: for each frame in [from, to], a Tracker (keyframes/tracker.h) estimates its
// camera-to-world pose in the first tracked frame's coordinates (the paper's windowed match first, then a wide
// search around a constant-velocity prediction, then relocalisation against earlier keyframes; implausible results
// rejected) and decides whether it is a keyframe. A frame that cannot be loaded, has no features with depth, has a
// timestamp not after the last tracked frame's, or that no try explains is skipped (its record says why) and the
// next frame is tried against the same last tracked frame. params.tracking = TrackingParams::paper_window_only()
// gives the paper's method alone.
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
#include "keyframes/tracker.h"
#include "keyframes/trajectory_io.h"

namespace rgbdcast {

struct SequenceParams {
  OdometryParams odometry;
  KeyframeParams keyframes;
  TrackingParams tracking;
  size_t from = 0;                                 // first frame index
  size_t to = std::numeric_limits<size_t>::max();  // last frame index, inclusive (clamped to the source)
  // For live tracking at 30 Hz on 2 cores: ORB (SIFT alone costs more than a 33 ms frame), exact in-window
  // matching, ICP on every second pixel with at most 12 iterations. Defaults otherwise.
  static SequenceParams live();
  Status validate() const;
};

struct FrameRecord {
  size_t index = 0;
  double timestamp = 0.0;
  int matches = 0;       // matches with the reference frame by the method used (0 for the first)
  int inliers = 0;       // RANSAC inliers
  bool tracked = false;  // has a pose
  bool keyframe = false;
  bool icp_used = false;
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();  // camera to world (first tracked frame = identity)
  double ms = 0.0;      // load + features + match + RANSAC (+ ICP) for this frame, excluding on_keyframe
  std::string message;  // why it was skipped, or notes (ICP not used, keyframe reason, callback error)
  TrackMethod method = TrackMethod::kNone;  // how the pose was found: first, window, wide, relocalised (none: skipped)
  int reference = -1;                       // frame index the pose was estimated against (-1: first frame or skipped)
  double track_ms = 0.0;  // tracking alone: features + match + RANSAC + ICP + keyframe decision (no load)
};

struct SequenceResult {
  std::vector<FrameRecord> frames;
  size_t tracked = 0, keyframes = 0, skipped = 0;
  size_t widened = 0, relocalised = 0;  // tracked frames whose pose came from the wide search / relocalisation
  Trajectory trajectory() const;        // the tracked frames' poses (index and timestamp set)
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
