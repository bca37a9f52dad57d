#include "keyframes/sequence.h"

#include <chrono>

#include "base/stopwatch.h"

namespace rgbdcast {

Status SequenceParams::validate() const {
  if (Status s = odometry.validate(); !s) return s;
  if (Status s = keyframes.validate(); !s) return s;
  if (Status s = tracking.validate(); !s) return s;
  if (from > to) return make_error(ErrorCode::kInvalidArgument, "sequence range: from > to");
  return ok_status();
}

SequenceParams SequenceParams::live() {
  SequenceParams p;
  p.odometry.features.type = FeatureType::kOrb;
  p.odometry.matching.exact_window = true;
  p.odometry.icp.image_step = 2;
  p.odometry.icp.max_iterations = 12;
  return p;
}

Trajectory SequenceResult::trajectory() const {
  Trajectory t;
  for (const FrameRecord& r : frames)
    if (r.tracked) t.poses.push_back({r.timestamp, static_cast<int>(r.index), r.pose});
  return t;
}

Result<SequenceResult> track_sequence(size_t frame_count, const FrameLoader& load, const SequenceParams& params,
                                      const KeyframeCallback& on_keyframe, const ProgressCallback& on_progress) {
  if (Status s = params.validate(); !s) return s.error();
  if (!load) return make_error(ErrorCode::kInvalidArgument, "sequence: no frame loader");
  if (frame_count == 0 || params.from >= frame_count)
    return make_error(ErrorCode::kInvalidArgument, "sequence: range starts at frame " + std::to_string(params.from) +
                                                       " but the source has " + std::to_string(frame_count) +
                                                       " frames");
  const size_t last = std::min(params.to, frame_count - 1);
  const size_t total = last - params.from + 1;

  SequenceResult out;
  Tracker tracker(params.odometry, params.tracking, params.keyframes);
  std::string first_failure;

  for (size_t i = params.from; i <= last; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    FrameRecord rec;
    rec.index = i;
    Result<RgbdFrame> frame = load(i);
    KeyframeDecision kd;
    if (!frame) {
      rec.message = "skipped: " + frame.error().message;
    } else {
      frame->index = static_cast<int>(i);
      rec.timestamp = frame->timestamp;
      const TrackStep step = tracker.push(*frame, &kd);
      rec.track_ms = step.features_ms + step.match_ms;
      rec.method = step.method;
      rec.matches = step.matches;
      if (!step.tracked()) {
        rec.message = "skipped: " + step.failure;
      } else {
        rec.tracked = true;
        rec.reference = step.reference;
        rec.inliers = step.inliers;
        rec.icp_used = step.icp_used;
        rec.pose = step.pose;
        rec.message = step.note;
        rec.keyframe = kd.keyframe;
        if (kd.keyframe) rec.message = "keyframe (" + kd.reason + ")" + (rec.message.empty() ? "" : "; " + rec.message);
      }
    }
    rec.ms = ms_since(t0);
    if (rec.tracked) {
      ++out.tracked;
      if (rec.keyframe) ++out.keyframes;
      if (rec.method == TrackMethod::kWide) ++out.widened;
      if (rec.method == TrackMethod::kRelocalised) ++out.relocalised;
      if (rec.keyframe && on_keyframe) {
        Status s = on_keyframe(*frame, rec);
        if (!s) rec.message += "; keyframe callback failed: " + s.error().message;
      }
    } else {
      ++out.skipped;
      if (first_failure.empty()) first_failure = rec.message;
    }
    out.frames.push_back(std::move(rec));
    if (on_progress) on_progress(out.frames.back(), out.frames.size(), total);
  }
  if (out.tracked == 0)
    return make_error(ErrorCode::kEmpty, "no frame of " + std::to_string(params.from) + ".." + std::to_string(last) +
                                             " could be tracked (first: " + first_failure + ")");
  return out;
}

}  // namespace rgbdcast
