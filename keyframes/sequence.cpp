#include "keyframes/sequence.h"

#include <chrono>
#include <optional>

namespace rgbdcast {

Status SequenceParams::validate() const {
  if (Status s = odometry.validate(); !s) return s;
  if (Status s = keyframes.validate(); !s) return s;
  if (from > to) return make_error(ErrorCode::kInvalidArgument, "sequence range: from > to");
  return ok_status();
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
                                                       " but the source has " + std::to_string(frame_count) + " frames");
  const size_t last = std::min(params.to, frame_count - 1);
  const size_t total = last - params.from + 1;

  SequenceResult out;
  KeyframeSelector selector(params.keyframes);
  struct Tracked {
    RgbdFrame frame;
    FrameFeatures features;
    Eigen::Matrix4d pose;
  };
  std::optional<Tracked> prev;
  std::string first_failure;

  for (size_t i = params.from; i <= last; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    FrameRecord rec;
    rec.index = i;
    auto finish = [&](FrameRecord& r) {
      r.ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      if (!r.tracked) {
        ++out.skipped;
        if (first_failure.empty()) first_failure = r.message;
      }
    };

    Result<RgbdFrame> frame = load(i);
    if (!frame) {
      rec.message = "skipped: " + frame.error().message;
      finish(rec);
      out.frames.push_back(rec);
      if (on_progress) on_progress(out.frames.back(), out.frames.size(), total);
      continue;
    }
    frame->index = static_cast<int>(i);
    rec.timestamp = frame->timestamp;
    if (prev && frame->timestamp != 0.0 && prev->frame.timestamp != 0.0 && frame->timestamp <= prev->frame.timestamp) {
      rec.message = "skipped: timestamp " + std::to_string(frame->timestamp) + " s is not after the last tracked " +
                    "frame's " + std::to_string(prev->frame.timestamp) + " s (out of order)";
      finish(rec);
      out.frames.push_back(rec);
      if (on_progress) on_progress(out.frames.back(), out.frames.size(), total);
      continue;
    }
    Result<FrameFeatures> features = detect_features(*frame, params.odometry.features);
    if (!features) {
      rec.message = "skipped: " + features.error().message;
      finish(rec);
      out.frames.push_back(rec);
      if (on_progress) on_progress(out.frames.back(), out.frames.size(), total);
      continue;
    }

    if (!prev) {
      rec.tracked = true;
      rec.pose = Eigen::Matrix4d::Identity();
    } else {
      const std::vector<FeatureMatch> matches = match_in_window(prev->features, *features, params.odometry.matching);
      rec.matches = static_cast<int>(matches.size());
      Result<PairEstimate> pair =
          estimate_motion(prev->frame, prev->features, *frame, *features, matches, params.odometry);
      if (!pair) {
        rec.message = "skipped: " + pair.error().message;
        finish(rec);
        out.frames.push_back(rec);
        if (on_progress) on_progress(out.frames.back(), out.frames.size(), total);
        continue;
      }
      rec.tracked = true;
      rec.matches = pair->matches;
      rec.inliers = pair->inliers;
      rec.icp_used = pair->icp_used;
      rec.pose = prev->pose * pair->cur_to_prev;
      rec.message = pair->note;
    }

    const KeyframeDecision kd = selector.consider(*frame, rec.pose, static_cast<int>(i));
    rec.keyframe = kd.keyframe;
    if (kd.keyframe) {
      rec.message = "keyframe (" + kd.reason + ")" + (rec.message.empty() ? "" : "; " + rec.message);
      ++out.keyframes;
    }
    ++out.tracked;
    finish(rec);
    if (rec.keyframe && on_keyframe) {
      Status s = on_keyframe(*frame, rec);
      if (!s) rec.message += "; keyframe callback failed: " + s.error().message;
    }
    prev = Tracked{std::move(*frame), std::move(*features), rec.pose};
    out.frames.push_back(rec);
    if (on_progress) on_progress(out.frames.back(), out.frames.size(), total);
  }
  if (out.tracked == 0)
    return make_error(ErrorCode::kEmpty, "no frame of " + std::to_string(params.from) + ".." + std::to_string(last) +
                                             " could be tracked (first: " + first_failure + ")");
  return out;
}

}  // namespace rgbdcast
