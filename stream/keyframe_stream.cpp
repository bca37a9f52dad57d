#include "stream/keyframe_stream.h"

#include <algorithm>
#include <chrono>
#include <nlohmann/json.hpp>
#include <thread>

#include "keyframes/trajectory_io.h"

namespace rgbdcast::stream {

namespace {

using steady = std::chrono::steady_clock;

double unix_now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

struct EncodedKeyframe {
  std::vector<std::uint8_t> glb;
  size_t triangles = 0;
};

// The one frame -> scene call, then the GLB as `rgbdcast reduce` writes it: mesh and capture camera in the
// keyframe's own camera frame (the world pose travels in the POST).
Result<EncodedKeyframe> encode_keyframe(const RgbdFrame& frame, FrameReductionOptions options, double budget_kb,
                                        const Eigen::Matrix4d& camera_to_world,
                                        const std::vector<CoverageView>& earlier) {
  options.budget_kb = budget_kb;
  auto textured = reduce_and_texture(frame, options, camera_to_world, earlier);
  if (!textured) return textured.error();
  EncodedKeyframe out;
  out.triangles = textured->node.mesh.triangle_count();
  textured->node.to_world = Eigen::Matrix4d::Identity();
  textured->camera.camera_to_world = Eigen::Matrix4d::Identity();
  const nlohmann::json extras = {{"rgbdcast",
                                  {{"source", frame.color_path},
                                   {"frame", frame.index},
                                   {"timestamp", frame.timestamp},
                                   {"reduction", nlohmann::json::parse(choices_json(*textured))}}}};
  const GlbWriteOptions glb_options = write_options(*textured, options.glb);
  Scene scene = frame_scene(std::move(*textured), extras.dump());
  auto glb = encode_glb(scene, glb_options);
  if (!glb) return glb.error();
  out.glb = std::move(*glb);
  return out;
}

Eigen::Matrix4d entry_pose(const OutboxEntry& e) {
  const auto& p = e.pose;
  return pose_from_tum(p[0], p[1], p[2], p[3], p[4], p[5], p[6]);
}

}  // namespace

Result<StreamSummary> run_stream(const FrameSource& source, Outbox& outbox, Sender& sender,
                                 const StreamOptions& options,
                                 const std::function<void(const StreamProgress&)>& on_progress,
                                 const std::function<bool()>& should_stop) {
  const auto t_start = steady::now();
  StreamSummary summary;
  StreamProgress progress;
  SequenceParams params = options.sequence;

  // Coverage views of the keyframes already in the outbox, in seq order (they are the deltas' reference).
  struct View {
    int seq;
    CoverageView view;
  };
  std::vector<View> views;
  Eigen::Matrix4d anchor = Eigen::Matrix4d::Identity();
  const std::vector<OutboxEntry> existing = outbox.entries();
  if (!existing.empty()) {
    summary.resumed = true;
    summary.resumed_entries = existing.size();
    const OutboxEntry& last = existing.back();
    summary.resumed_at_frame = last.frame_index;
    params.from = static_cast<size_t>(std::max(0, last.frame_index));
    anchor = entry_pose(last);
    for (const OutboxEntry& e : existing) {
      if (!e.rejected.empty()) continue;
      auto f = source.frame(static_cast<size_t>(e.frame_index));
      if (!f)
        return make_error(ErrorCode::kNotFound, "resuming from the outbox: keyframe " + std::to_string(e.seq) +
                                                    "'s frame " + std::to_string(e.frame_index) +
                                                    " cannot be reloaded from the input: " + f.error().message);
      views.push_back({e.seq, {f->intrinsics, f->depth_m, entry_pose(e)}});
    }
  }
  sender.start();

  auto earlier_than = [&](int seq) {
    std::vector<CoverageView> out;
    for (const View& v : views)
      if (v.seq < seq) out.push_back(v.view);
    return out;
  };

  // Frame timing.
  const auto& entries = source.entries();
  auto stamp = [&](size_t i) {
    const double t = i < entries.size() ? entries[i].color_timestamp : 0.0;
    return t > 0 ? t : static_cast<double>(i) / options.fps_without_timestamps;
  };
  std::optional<steady::time_point> start_steady;
  double start_unix = 0, first_stamp = 0, captured = 0;
  auto due = [&](size_t i) {
    return *start_steady + std::chrono::duration_cast<steady::duration>(
                               std::chrono::duration<double>(stamp(i) - first_stamp));
  };
  auto load = [&](size_t i) -> Result<RgbdFrame> {
    if (should_stop()) return make_error(ErrorCode::kUnavailable, "stopped");
    if (options.realtime) {
      if (!start_steady) {
        start_steady = steady::now();
        start_unix = unix_now();
        first_stamp = stamp(i);
      }
      const auto now = steady::now();
      if (i + 1 < source.size() && now >= due(i + 1)) {
        ++summary.dropped;
        return make_error(ErrorCode::kUnavailable, "dropped: a newer frame was already due (behind the camera)");
      }
      std::this_thread::sleep_until(due(i));
      captured = start_unix + (stamp(i) - first_stamp);
    } else {
      captured = unix_now();
    }
    return source.frame(i);
  };

  KeyframeInterval interval;
  FrameReductionOptions reduction = options.reduction;
  SmoothedDuration reduce_s(0.3);  // a keyframe's reduction time: mean + 2 deviations

  // --link-kbps-file: a changed value becomes the cap at once (the next budget and the sender's pacing follow it).
  std::optional<CapFile> cap_file;
  if (!options.link_kbps_file.empty()) cap_file.emplace(options.link_kbps_file);
  auto poll_cap = [&] {
    if (!cap_file) return;
    auto changed = cap_file->poll();
    if (!changed) {
      summary.errors.push_back(changed.error().message);
      return;
    }
    if (!*changed) return;
    sender.set_cap_kbps(**changed);
    ++summary.cap_changes;
  };
  poll_cap();

  auto coarsen_backlog = [&](int newest) {
    const double estimate = std::max(sender.estimate_kbps(), 1.0);
    const double limit_s = std::max(options.max_backlog_s, 2.0 * interval.seconds());
    std::vector<OutboxEntry> all = outbox.entries();
    double pending_bytes = 0;
    for (const OutboxEntry& e : all)
      if (e.pending()) pending_bytes += static_cast<double>(e.bytes);
    auto backlog_s = [&] { return pending_bytes * 8.0 / 1000.0 / estimate; };
    for (const OutboxEntry& e : all) {
      if (backlog_s() <= limit_s) break;
      if (!e.pending() || e.attempted || e.coarsened || e.seq == newest) continue;
      const double target_kb = std::max(options.budget.floor_kb, e.budget_kb * options.coarse_factor);
      if (target_kb * 1000.0 >= 0.9 * static_cast<double>(e.bytes)) continue;  // already about that small
      if (!sender.claim(e.seq)) continue;
      auto frame = source.frame(static_cast<size_t>(e.frame_index));
      if (frame) {
        frame->index = e.frame_index;
        auto coarse = encode_keyframe(*frame, reduction, target_kb, entry_pose(e), earlier_than(e.seq));
        if (coarse && coarse->glb.size() < e.bytes) {
          if (Status st = outbox.coarsen(e.seq, coarse->glb, target_kb, coarse->triangles); st) {
            pending_bytes -= static_cast<double>(e.bytes - coarse->glb.size());
            ++summary.coarsened;
          } else {
            summary.errors.push_back(st.error().message);
          }
        }
      }
      sender.release(e.seq);
    }
  };

  auto on_keyframe = [&](const RgbdFrame& frame, const FrameRecord& record) -> Status {
    if (summary.resumed && static_cast<int>(record.index) == summary.resumed_at_frame) return ok_status();
    const Eigen::Matrix4d pose = anchor * record.pose;
    interval.on_keyframe(std::chrono::duration<double>(steady::now() - t_start).count());
    const double tracked = unix_now();
    const double overhead_s = std::max(0.0, tracked - captured) + reduce_s.value() + sender.queue_wait_s() +
                              (sender.acknowledged_posts() == 0 ? options.latency.first_post_fixed_s : 0.0);
    const double budget_kb = next_keyframe_budget_kb(sender.estimate_kbps(), interval.seconds(), overhead_s,
                                                     options.latency, options.budget);
    const int seq = outbox.next_seq();
    const auto t_reduce = steady::now();
    auto encoded = encode_keyframe(frame, reduction, budget_kb, pose, earlier_than(seq));
    const double took = std::chrono::duration<double>(steady::now() - t_reduce).count();
    reduce_s.on_sample(took);
    if (!encoded) {
      if (encoded.error().code == ErrorCode::kEmpty) {
        ++summary.covered;
        return ok_status();
      }
      ++summary.failed;
      summary.errors.push_back("frame " + std::to_string(record.index) + ": " + encoded.error().message);
      return encoded.error();
    }
    OutboxEntry e;
    e.frame_index = static_cast<int>(record.index);
    e.timestamp = frame.timestamp;
    e.pose = pose_to_tum(pose.data());
    e.captured = captured;
    e.budget_kb = budget_kb;
    e.triangles = encoded->triangles;
    e.tracked = tracked;
    e.reduced = unix_now();
    auto added = outbox.add(e, encoded->glb);
    if (!added) {
      ++summary.failed;
      summary.errors.push_back(added.error().message);
      return added.error();
    }
    views.push_back({added->seq, {frame.intrinsics, frame.depth_m, pose}});
    ++summary.keyframes;
    progress.keyframes = summary.keyframes;
    progress.budget_kb = budget_kb;
    progress.interval_s = interval.seconds();
    progress.overhead_s = overhead_s;
    sender.notify();
    coarsen_backlog(added->seq);
    return ok_status();
  };
  auto on_frame = [&](const FrameRecord& r, size_t done, size_t total) {
    poll_cap();
    progress.frames_done = done;
    progress.frames_total = total;
    progress.tracking = r.tracked ? (r.icp_used ? "tracked (ICP)" : "tracked") : r.message;
    progress.sender = sender.stats();
    if (on_progress) on_progress(progress);
  };

  auto result = track_sequence(source.size(), load, params, on_keyframe, on_frame);
  if (!result) {
    sender.stop();
    return result.error();
  }
  summary.frames = result->frames.size();
  summary.tracked = result->tracked;

  // Drain: until the sender has nothing pending, stops for good, or stop is asked.
  progress.draining = true;
  for (;;) {
    poll_cap();
    progress.sender = sender.stats();
    if (on_progress) on_progress(progress);
    if (progress.sender.pending == 0 || !progress.sender.fatal.empty()) break;
    if (should_stop()) {
      summary.stopped = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  sender.stop();
  summary.sender = sender.stats();
  summary.stopped = summary.stopped || should_stop();
  summary.seconds = std::chrono::duration<double>(steady::now() - t_start).count();
  if (!summary.sender.fatal.empty()) return make_error(ErrorCode::kUnavailable, summary.sender.fatal);
  return summary;
}

}  // namespace rgbdcast::stream
