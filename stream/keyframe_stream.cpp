#include "stream/keyframe_stream.h"

#include <sched.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>

#include "keyframes/trajectory_io.h"
#include "stream/camera_reader.h"

namespace rgbdcast::stream {

namespace {

using steady = std::chrono::steady_clock;

double unix_now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

struct EncodedKeyframe {
  std::vector<std::uint8_t> glb;
  size_t triangles = 0;
  bool fits = false;  // the budget's rule "fits": the finest mesh and best quality its settings allow, under budget
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
  out.fits = textured->budget.rule == "fits";
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

Eigen::Matrix4d tum_pose(const std::array<double, 7>& p) {
  return pose_from_tum(p[0], p[1], p[2], p[3], p[4], p[5], p[6]);
}
Eigen::Matrix4d entry_pose(const OutboxEntry& e) { return tum_pose(e.pose); }

double thread_cpu_ms() {
  timespec ts{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

// Linux: niceness is per thread, and threads created later by this one inherit it.
void renice_this_thread(int increment) {
  if (increment <= 0) return;
  const auto tid = static_cast<id_t>(::syscall(SYS_gettid));
  errno = 0;
  const int now = ::getpriority(PRIO_PROCESS, tid);
  if (errno == 0) ::setpriority(PRIO_PROCESS, tid, std::min(19, now + increment));
}

// Linux: the idle scheduling class for this thread (and the threads it creates later): it runs on a core nothing
// else wants, so a refinement made between keyframes takes no CPU from the tracker or a keyframe's reduction.
// Returns the thread's id, for back_to_normal.
pid_t idle_this_thread() {
  const auto tid = static_cast<pid_t>(::syscall(SYS_gettid));
  sched_param sp{};
  sp.sched_priority = 0;
  ::sched_setscheduler(tid, SCHED_IDLE, &sp);
  return tid;
}
// The normal class again (its niceness kept): once tracking is done, a refinement still being reduced is what the
// drain waits for, and an idle-class thread on a loaded machine may not run for seconds.
void back_to_normal(pid_t tid) {
  sched_param sp{};
  sp.sched_priority = 0;
  ::sched_setscheduler(tid, SCHED_OTHER, &sp);
}

// A tracked keyframe on its way to the reduction thread.
struct KeyframeJob {
  RgbdFrame frame;
  int frame_index = 0;
  Eigen::Matrix4d pose;   // camera to world, in the mission's world
  double captured = 0, tracked = 0;
  bool resumed = false;   // a deferred keyframe reloaded from the outbox's records
};

DeferredKeyframe deferred_record(const KeyframeJob& job) {
  DeferredKeyframe k;
  k.frame_index = job.frame_index;
  k.timestamp = job.frame.timestamp;
  k.pose = pose_to_tum(job.pose.data());
  k.captured = job.captured;
  k.tracked = job.tracked;
  return k;
}

}  // namespace

Percentiles percentiles(std::vector<double> v) {
  Percentiles out;
  if (v.empty()) return out;
  std::sort(v.begin(), v.end());
  auto at = [&](double p) {
    const double k = (static_cast<double>(v.size()) - 1) * p;
    const size_t lo = static_cast<size_t>(k), hi = std::min(lo + 1, v.size() - 1);
    return v[lo] + (v[hi] - v[lo]) * (k - static_cast<double>(lo));
  };
  out.p50 = at(0.5);
  out.p95 = at(0.95);
  return out;
}

FrameReductionOptions reduction_for_budget(const FrameReductionOptions& base, const FineReduction& fine,
                                           double budget_kb) {
  FrameReductionOptions o = base;
  if (fine.above_kb > 0 && budget_kb > fine.above_kb) {
    o.params.depth_mesh.tolerance_factor = std::min(o.params.depth_mesh.tolerance_factor, fine.tolerance);
    o.params.depth_mesh.simplify_px = std::min(o.params.depth_mesh.simplify_px, fine.simplify_px);
    o.budget_max_jpeg_quality = std::max(o.budget_max_jpeg_quality, fine.max_jpeg_quality);
  }
  return o;
}

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
  std::mutex views_mu;  // views: appended by the reduction thread, read by it and by the refinements
  Eigen::Matrix4d anchor = Eigen::Matrix4d::Identity();
  const std::vector<OutboxEntry> existing = outbox.entries();
  const std::vector<DeferredKeyframe> waiting = outbox.deferred();  // by frame
  std::deque<KeyframeJob> deferred;  // held back while a newer keyframe went first, oldest first
  if (!existing.empty() || !waiting.empty()) {
    summary.resumed = true;
    summary.resumed_entries = existing.size();
    summary.resumed_deferred = waiting.size();
    // Tracking restarts at the latest keyframe's frame, added or deferred (after an outage, deferred keyframes have
    // higher seqs but older frames; a deferred one's frame lies before the newer keyframes that went first).
    int last_frame = -1;
    for (const OutboxEntry& e : existing)
      if (e.frame_index > last_frame) {
        last_frame = e.frame_index;
        anchor = entry_pose(e);
      }
    if (!waiting.empty() && waiting.back().frame_index > last_frame) {
      last_frame = waiting.back().frame_index;
      anchor = tum_pose(waiting.back().pose);
    }
    summary.resumed_at_frame = last_frame;
    params.from = static_cast<size_t>(std::max(0, last_frame));
    auto reload = [&](int frame_index, const std::string& what) -> Result<RgbdFrame> {
      auto f = source.frame(static_cast<size_t>(frame_index));
      if (!f)
        return make_error(ErrorCode::kNotFound, "resuming from the outbox: " + what + "'s frame " +
                                                    std::to_string(frame_index) +
                                                    " cannot be reloaded from the input: " + f.error().message);
      f->index = frame_index;
      return f;
    };
    for (const OutboxEntry& e : existing) {
      if (!e.rejected.empty()) continue;
      auto f = reload(e.frame_index, "keyframe " + std::to_string(e.seq));
      if (!f) return f.error();
      views.push_back({e.seq, {f->intrinsics, f->depth_m, entry_pose(e)}});
    }
    // The deferred keyframes wait again, as they did when the sender stopped (the reduction thread reduces them,
    // coarsened, newest first, whenever no newer keyframe is waiting and the link has room).
    for (const DeferredKeyframe& k : waiting) {
      auto f = reload(k.frame_index, "deferred keyframe");
      if (!f) return f.error();
      KeyframeJob job;
      job.frame = std::move(*f);
      job.frame_index = k.frame_index;
      job.pose = tum_pose(k.pose);
      job.captured = k.captured;
      job.tracked = k.tracked;
      job.resumed = true;
      deferred.push_back(std::move(job));
    }
  }
  sender.start();

  auto earlier_than = [&](int seq) {
    std::lock_guard lock(views_mu);
    std::vector<CoverageView> out;
    for (const View& v : views)
      if (v.seq < seq) out.push_back(v.view);
    return out;
  };

  // The camera: a reader thread one frame ahead of the tracker (at the frames' own times in realtime).
  std::mutex source_mu;  // the reader's and the reduction thread's reads of the source
  CameraReaderOptions ro;
  ro.realtime = options.realtime;
  ro.fps_without_timestamps = options.fps_without_timestamps;
  ro.from = params.from;
  ro.last = source.size() == 0 ? 0 : std::min(params.to, source.size() - 1);
  std::optional<CameraReader> camera;
  if (source.size() > 0 && ro.from <= ro.last) camera.emplace(source, ro, source_mu);
  double captured = 0;
  // Per frame read: when its work began (it was due, or the read started), the reader's CPU time for it and the
  // tracker thread's CPU clock when the tracker took it.
  std::optional<steady::time_point> frame_began;
  double frame_read_cpu_ms = 0, frame_cpu_began = 0;
  auto load = [&](size_t i) -> Result<RgbdFrame> {
    if (should_stop()) return make_error(ErrorCode::kUnavailable, "stopped");
    if (!camera) return make_error(ErrorCode::kNotFound, "frame " + std::to_string(i) + " is not in the source");
    auto taken = camera->take(i);
    if (!taken) return taken.error();
    captured = taken->captured;
    frame_began = taken->began;
    frame_read_cpu_ms = taken->read_cpu_ms;
    frame_cpu_began = thread_cpu_ms();
    return std::move(taken->frame);
  };

  const size_t sender_lanes = sender.stats().lanes;
  KeyframeInterval interval;
  double last_keyframe_s = 0;  // since t_start: when the last keyframe was tracked (mu)
  const FrameReductionOptions reduction = options.reduction;
  // The reduction for a budget: above fine.above_kb, the finer settings (FineReduction).
  auto reduction_for = [&](double budget_kb) { return reduction_for_budget(reduction, options.fine, budget_kb); };
  // Revisions whose reduction "fit" (pipeline/frame_scene.h: the finest mesh and best JPEG quality of its settings,
  // under its budget): seq -> that revision's bytes and budget. A larger budget at the same settings gives the same
  // GLB, so such a revision is refined only at a budget whose settings differ (FineReduction). On TUM at 2 Mbit/s
  // each run reduced 8 refinements and kept none (under kRefinementKeepRatio x the bytes); 5-7 of them were of
  // revisions that fit, and are no longer made (BENCHMARKS.md stop 25).
  struct Fit {
    size_t bytes = 0;
    double budget_kb = 0;
  };
  std::map<int, Fit> fits;
  std::mutex fits_mu;
  auto note_fit = [&](int seq, const EncodedKeyframe& k, double budget_kb) {
    std::lock_guard lock(fits_mu);
    if (k.fits)
      fits[seq] = {k.glb.size(), budget_kb};
    else
      fits.erase(seq);
  };
  // True when refining e at budget_kb can only give its GLB again.
  auto saturated = [&](const OutboxEntry& e, double budget_kb) {
    std::lock_guard lock(fits_mu);
    const auto f = fits.find(e.seq);
    if (f == fits.end() || f->second.bytes != e.bytes || f->second.budget_kb != e.budget_kb) return false;
    const double above = options.fine.above_kb;
    return !(above > 0) || (budget_kb > above) == (f->second.budget_kb > above);
  };
  SmoothedDuration reduce_s(0.3);  // a keyframe's reduction time: mean + 2 deviations
  SmoothedDuration refine_s(0.5);  // a refinement's (a larger budget takes longer)

  // --link-kbps-file: a changed value becomes the cap at once (the next budget and the sender's pacing follow it).
  std::optional<CapFile> cap_file;
  if (!options.link_kbps_file.empty()) cap_file.emplace(options.link_kbps_file);
  std::mutex mu;  // summary, progress and interval: shared by the tracker's and the reduction thread
  auto poll_cap = [&] {
    if (!cap_file) return;
    auto changed = cap_file->poll();
    std::lock_guard lock(mu);
    if (!changed) {
      summary.errors.push_back(changed.error().message);
      return;
    }
    if (!*changed) return;
    sender.set_cap_kbps(**changed);
    ++summary.cap_changes;
  };
  poll_cap();

  // Runs on the reduction thread only.
  auto coarsen_backlog = [&](int newest, double interval_s) {
    const double estimate = std::max(sender.estimate_kbps(), 1.0);
    const double limit_s = std::max(options.max_backlog_s, 2.0 * interval_s);
    std::vector<OutboxEntry> all = outbox.entries();
    double pending_bytes = 0;
    for (const OutboxEntry& e : all)
      if (e.pending() && e.rev == 0) pending_bytes += static_cast<double>(e.bytes);  // refinements go last anyway
    auto backlog_s = [&] { return pending_bytes * 8.0 / 1000.0 / estimate; };
    for (const OutboxEntry& e : all) {
      if (backlog_s() <= limit_s) break;
      if (!e.pending() || e.attempted || e.coarsened || e.rev > 0 || e.seq == newest) continue;
      const double target_kb = std::max(options.budget.floor_kb, e.budget_kb * options.coarse_factor);
      if (target_kb * 1000.0 >= 0.9 * static_cast<double>(e.bytes)) continue;  // already about that small
      if (!sender.claim(e.seq)) continue;
      auto frame = [&] {
        std::lock_guard lock(source_mu);
        return source.frame(static_cast<size_t>(e.frame_index));
      }();
      if (frame) {
        frame->index = e.frame_index;
        auto coarse = encode_keyframe(*frame, reduction_for(target_kb), target_kb, entry_pose(e), earlier_than(e.seq));
        if (coarse && coarse->glb.size() < e.bytes) {
          Status st = outbox.coarsen(e.seq, coarse->glb, target_kb, coarse->triangles);
          std::lock_guard lock(mu);
          if (st) {
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

  // Deferred keyframes beyond max_deferred: the oldest are dropped (their records removed: a documented drop, counted
  // in deferred_dropped). Called with mu held (or before the reduction thread starts); returns the dropped frames,
  // whose records forget_deferred removes (outside mu: a file operation).
  auto trim_deferred = [&] {
    std::vector<int> dropped;
    while (deferred.size() > options.max_deferred) {
      dropped.push_back(deferred.front().frame_index);
      deferred.pop_front();
      ++summary.deferred_dropped;
    }
    return dropped;
  };
  auto forget_deferred = [&](int frame_index) {
    if (Status st = outbox.undefer(frame_index); !st) {
      std::lock_guard lock(mu);
      summary.errors.push_back(st.error().message);
    }
  };

  // The first keyframe's refinement, reduced beside the keyframe itself (reduce_keyframe below) and taken by
  // refine_one instead of reducing it again. Only the reduction thread starts, takes and drops it.
  struct Prefetch {
    int seq = -1;
    double budget_kb = 0;
    std::thread thread;
    std::optional<Result<EncodedKeyframe>> result;
    double took_s = 0;
  };
  Prefetch prefetch;
  auto drop_prefetch = [&] {
    if (prefetch.thread.joinable()) prefetch.thread.join();
    prefetch = Prefetch{};
  };
  // The prefetched refinement of `seq` at `budget_kb`, once it is done; nothing when there is none for them.
  auto take_prefetch = [&](int seq, double budget_kb) -> std::optional<Result<EncodedKeyframe>> {
    if (prefetch.seq < 0) return std::nullopt;
    if (prefetch.thread.joinable()) prefetch.thread.join();
    std::optional<Result<EncodedKeyframe>> out;
    if (prefetch.seq == seq && prefetch.budget_kb == budget_kb && prefetch.result) out = std::move(prefetch.result);
    prefetch = Prefetch{};
    return out;
  };

  // The reduction thread's work for one keyframe: budget, the one frame -> scene call, the outbox, the backlog rule.
  // `was_deferred`: a keyframe the backlog rule held back while a newer one went first; it is coarsened, and its record
  // goes once it is handled (Outbox::add removes it with the entry; a keyframe with nothing new or whose reduction
  // failed leaves nothing to add; one whose outbox write failed keeps it, for a resumed run). Returns its seq once it
  // reached the outbox, else -1.
  auto reduce_keyframe = [&](const KeyframeJob& job, bool was_deferred) {
    double interval_s = 0;
    {
      std::lock_guard lock(mu);
      interval_s = interval.seconds();
    }
    const double overhead_s = std::max(0.0, unix_now() - job.captured) + reduce_s.value() + sender.queue_wait_s() +
                              (sender.acknowledged_posts() == 0 ? options.latency.first_post_fixed_s : 0.0);
    const double line_kbps = sender.line_kbps(), fixed_s = sender.post_fixed_s();
    // The rate rule's fixed cost: with two lanes or more, a POST's round trip and the server's time overlap the next
    // keyframe's body on the line (the sender starts it once the body before it is across), so the line can carry a
    // keyframe's bytes for the whole interval; with one lane it cannot. The latency rule always counts it: it is in
    // this keyframe's time to the view.
    const double rate_fixed_s = sender_lanes > 1 ? 0.0 : fixed_s;
    const double budget_kb =
        was_deferred
            ? std::max(options.budget.floor_kb,
                       options.coarse_factor * keyframe_budget_kb(line_kbps, interval_s, options.budget, rate_fixed_s))
            : std::min(keyframe_budget_kb(line_kbps, interval_s, options.budget, rate_fixed_s),
                       latency_budget_kb(line_kbps, overhead_s, options.latency, options.budget, fixed_s));
    const int seq = outbox.next_seq();
    // Before any answer, under a cap with refinements that yield, the first keyframe is refined at once at the cap's
    // budget and its refinement goes beside its first POST (the reduction thread's loop, below). That refinement is
    // reduced here, beside the keyframe's own reduction, on a thread niced below it: made only after the keyframe was
    // written, it was ready 50-60 ms after the first body had crossed the line, which idled meanwhile (BENCHMARKS.md,
    // stop 23). The budget is the one refine_one asks for then (what the cap carries in the window); when refine_one
    // asks for another, or the keyframe does not qualify, the prefetched one is dropped.
    const double ahead_kb = refinement_budget_kb(sender.cap_kbps(), options.refine_window_s, 0.0,
                                                 options.refine_ceiling_kb, options.budget.headroom);
    if (!was_deferred && options.refine_ceiling_kb > 0 && sender.cap_kbps() > 0 && sender.refinements_yield() &&
        sender.acknowledged_posts() == 0 && prefetch.seq < 0 && ahead_kb >= std::max(1.25 * budget_kb, budget_kb + 8)) {
      prefetch.seq = seq;
      prefetch.budget_kb = ahead_kb;
      prefetch.thread = std::thread([&prefetch, &reduction_for, frame = job.frame, pose = job.pose,
                                     views = earlier_than(seq), nice = std::max(1, options.reduce_nice)] {
        renice_this_thread(nice);
        const auto t0 = steady::now();
        prefetch.result = encode_keyframe(frame, reduction_for(prefetch.budget_kb), prefetch.budget_kb, pose, views);
        prefetch.took_s = std::chrono::duration<double>(steady::now() - t0).count();
      });
    }
    const auto t_reduce = steady::now();
    auto encoded = encode_keyframe(job.frame, reduction_for(budget_kb), budget_kb, job.pose, earlier_than(seq));
    const double took = std::chrono::duration<double>(steady::now() - t_reduce).count();
    {
      std::lock_guard lock(mu);  // (the refiner reads reduce_s under mu)
      reduce_s.on_sample(took);
      summary.reduce_ms.push_back(1000.0 * took);
    }
    if (!encoded) {
      if (was_deferred) forget_deferred(job.frame_index);
      std::lock_guard lock(mu);
      if (encoded.error().code == ErrorCode::kEmpty) {
        ++summary.covered;
        return -1;
      }
      ++summary.failed;
      summary.errors.push_back("frame " + std::to_string(job.frame_index) + ": " + encoded.error().message);
      return -1;
    }
    OutboxEntry e;
    e.frame_index = job.frame_index;
    e.timestamp = job.frame.timestamp;
    e.pose = pose_to_tum(job.pose.data());
    e.captured = job.captured;
    e.budget_kb = budget_kb;
    e.triangles = encoded->triangles;
    e.tracked = job.tracked;
    e.reduced = unix_now();
    e.coarsened = was_deferred;
    auto added = outbox.add(e, encoded->glb);
    if (!added) {
      std::lock_guard lock(mu);
      ++summary.failed;
      summary.errors.push_back(added.error().message);
      return -1;
    }
    note_fit(added->seq, *encoded, budget_kb);
    {
      std::lock_guard views_lock(views_mu);
      views.push_back({added->seq, {job.frame.intrinsics, job.frame.depth_m, job.pose}});
    }
    {
      std::lock_guard lock(mu);
      ++summary.keyframes;
      progress.keyframes = summary.keyframes;
      progress.budget_kb = budget_kb;
      progress.interval_s = interval_s;
      progress.overhead_s = overhead_s;
    }
    sender.notify();
    coarsen_backlog(added->seq, interval_s);
    return added->seq;
  };

  // Refinements: the newest acknowledged keyframe whose revision now (or the last refinement tried of it) was made at
  // a budget the window beats by 1.25 x and 8 kB, reduced again at what the link carries in window_s (at most
  // refine_window_s), as its next revision. With `ahead` (the drain, and the reduction thread before any answer),
  // when no acknowledged keyframe qualifies, one whose POST is out (not answered yet, the link not down) may be: its
  // refinement is reduced while that POST is on the line and added once it is acknowledged (Outbox::revise needs the
  // answer), so the line does not idle for the reduction (a single keyframe's stream, ICL: its only refinement
  // followed its answer 0.3-0.6 s later). Before any answer has measured the link, that is done only under a cap, at
  // what the cap carries in the window (the estimate never exceeds the cap, so no measured budget is larger): when
  // refinements yield to keyframes (Sender::refinements_yield) and the POST is still out, the revision is added at
  // once (Outbox::revise_in_flight) and goes beside it, so the line carries it while the first answer is awaited;
  // otherwise, once the answer comes, it is added if the measured link carries its bytes in the window, else dropped
  // and the keyframe refined again at the measured budget, as it is without a cap. Returns false when there is no
  // such keyframe (or another thread is refining); true when one was handled (refined, or not kept: the new GLB was
  // under kRefinementKeepRatio x the old one's bytes, or too large for the measured link, or its first POST was
  // rejected or never answered before a stop; it is tried again only at a larger budget, or at once when it was too
  // large). A revision that fits its budget is not refined at settings that would give it again (saturated). Called by
  // the refiner thread and the reduction thread while tracking, then by the drain; one at a time (refine_mu).
  std::map<int, double> refined_at;  // seq -> the largest budget a refinement of it was reduced at (refine_mu)
  std::set<std::pair<int, int>> saturated_seen;  // (seq, rev) counted in refine_saturated (refine_mu)
  std::mutex refine_mu;
  std::atomic<bool> tracking_done_for_refiner{false};  // the drain's refinements are not counted as while tracking
  // only_seq >= 0: that keyframe or none.
  auto refine_one = [&](double window_s, SmoothedDuration& took_s, bool ahead, int only_seq = -1) {
    if (!(options.refine_ceiling_kb > 0)) return false;
    std::unique_lock refining(refine_mu, std::try_to_lock);
    if (!refining) return false;
    const double window = std::min(window_s, options.refine_window_s);
    auto carried_kb = [&](double line_kbps, double fixed_s) {  // what the line carries in the window
      return refinement_budget_kb(line_kbps, window, fixed_s, options.refine_ceiling_kb, options.budget.headroom);
    };
    const double measured_kb = carried_kb(sender.line_kbps(), sender.post_fixed_s());
    // Acknowledged ones first; then, ahead, one whose POST is out. Without a cap only once an answer has measured
    // the link: a budget from the initial guess would be replaced by the next refinement as soon as the link is
    // known (ICL at 2 Mbit/s: a 52 kB revision, then a 133 kB one). Under a cap, before that answer, at the cap's
    // budget (checked against the measured link when the answer comes, below).
    const bool measured = sender.acknowledged_posts() > 0;
    const double cap_kbps = sender.cap_kbps();
    const bool from_cap = !measured && cap_kbps > 0;
    const double ahead_kb = from_cap ? carried_kb(cap_kbps, 0.0) : measured_kb;
    std::optional<OutboxEntry> best;
    double budget_kb = measured_kb;
    const std::vector<OutboxEntry> all = outbox.entries();
    for (bool answered : {true, false}) {
      if (best || (!answered && !(ahead && (measured || from_cap) && !sender.stats().link_down))) break;
      const double kb = answered ? measured_kb : ahead_kb;
      for (const OutboxEntry& e : all) {
        const auto tried = refined_at.find(e.seq);
        const double base = std::max(e.budget_kb, tried == refined_at.end() ? 0.0 : tried->second);
        // Ahead from the cap, a keyframe just added qualifies before its lane marks it attempted (by the time its
        // refinement is reduced it is: the sender takes a keyframe at once when nothing else waits).
        const bool state =
            answered ? e.acked : (!e.acked && (e.attempted || (from_cap && e.rev == 0)) && e.rejected.empty());
        if (!state || (only_seq >= 0 && e.seq != only_seq) || kb < std::max(1.25 * base, base + 8)) continue;
        if (saturated(e, kb)) {
          if (saturated_seen.insert({e.seq, e.rev}).second) {
            std::lock_guard lock(mu);
            ++summary.refine_saturated;
          }
          continue;
        }
        if (!best || e.captured > best->captured || (e.captured == best->captured && e.seq > best->seq)) {
          best = e;
          budget_kb = kb;
        }
      }
    }
    if (!best) return false;
    const bool made_ahead = !best->acked, made_from_cap = made_ahead && from_cap;
    refined_at[best->seq] = budget_kb;
    // Reduced already beside the keyframe (the reduction thread's first keyframe), or reduced now from its frame.
    std::optional<Result<EncodedKeyframe>> prefetched;
    bool beside_keyframe = false;
    if (only_seq >= 0 && prefetch.seq >= 0) {
      if (prefetch.thread.joinable()) prefetch.thread.join();
      const double prefetch_took_s = prefetch.took_s;
      prefetched = take_prefetch(best->seq, budget_kb);
      if (prefetched) took_s.on_sample(prefetch_took_s);
      beside_keyframe = prefetched.has_value();
    }
    if (!prefetched) {
      auto frame = [&] {
        std::lock_guard lock(source_mu);
        return source.frame(static_cast<size_t>(best->frame_index));
      }();
      if (!frame) {
        std::lock_guard lock(mu);
        summary.errors.push_back("refining keyframe " + std::to_string(best->seq) + ": " + frame.error().message);
        return true;
      }
      frame->index = best->frame_index;
      const auto t0 = steady::now();
      prefetched = encode_keyframe(*frame, reduction_for(budget_kb), budget_kb, entry_pose(*best),
                                   earlier_than(best->seq));
      took_s.on_sample(std::chrono::duration<double>(steady::now() - t0).count());
    }
    auto& fine = *prefetched;
    if (!fine) return true;
    if (static_cast<double>(fine->glb.size()) < kRefinementKeepRatio * static_cast<double>(best->bytes)) {
      std::lock_guard lock(mu);
      ++summary.refined_not_kept;
      return true;
    }
    // From the cap, with refinements that yield: beside the first revision's POST if it is still out.
    if (made_from_cap && sender.refinements_yield()) {
      auto now = outbox.entry(best->seq);
      // Reduced beside its keyframe, the refinement can be ready before a lane has taken the keyframe and marked it
      // attempted (it read the GLB first, stream/sender.cpp): wait for that (a lane takes it at once when nothing
      // else waits), not for the answer. Without the wait it went after the answer (1 of 16 runs, BENCHMARKS.md
      // stop 23).
      for (int i = 0; beside_keyframe && i < 300 && now && now->rev == best->rev && now->pending() &&
                      !now->attempted && !should_stop();
           ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
        now = outbox.entry(best->seq);
      }
      if (now && now->rev == best->rev && now->attempted && now->pending())
        if (outbox.revise_in_flight(best->seq, fine->glb, budget_kb, fine->triangles)) {
          note_fit(best->seq, *fine, budget_kb);
          {
            std::lock_guard lock(mu);
            ++summary.refined;
            ++summary.refined_ahead;
            if (beside_keyframe) ++summary.refined_beside_keyframe;
            if (!tracking_done_for_refiner) ++summary.refined_while_tracking;
          }
          sender.notify();
          return true;
        }
    }
    // The reduction thread does not wait for an answer (the next keyframe would wait with it): the drain or the
    // refiner thread makes the refinement again once the keyframe qualifies there.
    if (only_seq >= 0 && !best->acked) {
      auto now = outbox.entry(best->seq);
      if (!now || !now->acked || now->rev != best->rev) {
        refined_at.erase(best->seq);
        return true;
      }
      best = std::move(now);  // answered meanwhile: checked against the measured link below
    }
    while (!best->acked) {  // made ahead: wait for the answer to the revision it replaces
      if (should_stop() || !sender.stats().fatal.empty()) return true;
      if (sender.stats().link_down) {  // an outage: not worth holding the drain (its cap polls) for; made again later
        refined_at.erase(best->seq);
        return true;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
      auto now = outbox.entry(best->seq);
      if (!now || !now->rejected.empty() || now->rev != best->rev) return true;
      best = std::move(now);
    }
    // Sized to the cap before the link was measured: added only if the measured link carries it in the window;
    // otherwise the next call refines the keyframe at the measured budget (as without a cap).
    if (made_from_cap &&
        static_cast<double>(fine->glb.size()) > 1000.0 * carried_kb(sender.line_kbps(), sender.post_fixed_s())) {
      refined_at.erase(best->seq);
      std::lock_guard lock(mu);
      ++summary.refined_ahead_redone;
      return true;
    }
    Status st = outbox.revise(best->seq, fine->glb, budget_kb, fine->triangles);
    if (st) note_fit(best->seq, *fine, budget_kb);
    {
      std::lock_guard lock(mu);
      if (st) {
        ++summary.refined;
        if (!tracking_done_for_refiner) ++summary.refined_while_tracking;
        if (made_ahead) ++summary.refined_ahead;
        if (beside_keyframe) ++summary.refined_beside_keyframe;
      } else {
        summary.errors.push_back(st.error().message);
      }
    }
    sender.notify();
    return true;
  };

  for (int frame_index : trim_deferred()) forget_deferred(frame_index);  // resumed with a smaller max_deferred
  std::deque<KeyframeJob> jobs;
  bool tracking_done = false, reducing = false, holding = false;
  std::condition_variable jobs_cv;
  // Hold the next keyframe back while the sender owes more (Sender::owed_s: the paced line's remaining time and the
  // pending bytes not yet started) than its reduction is expected to take: reduced now, it would wait for the line.
  auto link_owes_too_much = [&] {
    return options.supersede && sender.owed_s() > std::max(reduce_s.value(), 0.1);
  };
  std::thread reducer([&] {
    renice_this_thread(options.reduce_nice);
    for (;;) {
      std::unique_lock lock(mu);
      jobs_cv.wait_for(lock, std::chrono::milliseconds(50),
                       [&] { return !jobs.empty() || !deferred.empty() || tracking_done; });
      // Stopped: queued keyframes never reached the outbox (a resumed run tracks their frames again); deferred ones
      // have their records beside it (a resumed run reduces them).
      if (should_stop()) return;
      // Nothing to reduce: refinements wait for the drain. One made here between keyframes delays the next
      // keyframe's reduction, which the latency rule pays for in that keyframe's bytes (BENCHMARKS.md, stop 17).
      if (jobs.empty() && deferred.empty()) {
        if (tracking_done) return;
        continue;
      }
      // Held back while the link owes too much; a newer keyframe tracked meanwhile goes first, the older waits.
      lock.unlock();
      const bool hold = link_owes_too_much();
      lock.lock();
      if (should_stop()) return;
      if (hold) {
        lock.unlock();
        if (!sender.stats().fatal.empty()) return;  // the sender stopped for good: the link will not free
        lock.lock();
        if (!holding) {
          holding = true;
          jobs_cv.notify_all();  // a tracker waiting for this reduction goes on (and may supersede it)
        }
        // Each deferred keyframe's record goes to the outbox's folder, so that a stop does not lose it; written
        // outside mu (the tracker takes it on every frame). Only this thread reads and changes `deferred`.
        std::vector<DeferredKeyframe> records;
        while (jobs.size() > 1) {
          records.push_back(deferred_record(jobs.front()));
          deferred.push_back(std::move(jobs.front()));
          jobs.pop_front();
          ++summary.superseded;
        }
        const std::vector<int> dropped = trim_deferred();
        if (!records.empty() || !dropped.empty()) {
          lock.unlock();
          for (const DeferredKeyframe& k : records)
            if (Status st = outbox.defer(k); !st) {
              std::lock_guard errors_lock(mu);
              summary.errors.push_back("deferred keyframe of frame " + std::to_string(k.frame_index) +
                                       " not persisted (a stop loses it): " + st.error().message);
            }
          for (int frame_index : dropped) forget_deferred(frame_index);
          lock.lock();
        }
        jobs_cv.wait_for(lock, std::chrono::milliseconds(50));
        continue;
      }
      holding = false;
      const bool is_deferred = jobs.empty();
      KeyframeJob job;
      if (is_deferred) {  // the newest deferred one first
        job = std::move(deferred.back());
        deferred.pop_back();
      } else {
        job = std::move(jobs.front());
        jobs.pop_front();
      }
      reducing = true;
      lock.unlock();
      const int written_seq = reduce_keyframe(job, is_deferred);
      const bool written = written_seq >= 0;
      lock.lock();
      reducing = false;
      if (is_deferred && written) ++(job.resumed ? summary.resumed_deferred_sent : summary.deferred_sent);
      const bool idle = jobs.empty() && deferred.empty();
      lock.unlock();
      jobs_cv.notify_all();
      // Before any answer, under a cap with refinements that yield: the keyframe just written (sized to the initial
      // estimate) is refined at once at the cap's budget and its refinement goes beside its first POST, so the line
      // carries it while that POST's answer is awaited (the refiner thread would wait for the body to cross first,
      // and the drain for tracking to end). Only until the first answer: a keyframe tracked meanwhile waits for it.
      if (written && idle && sender.acknowledged_posts() == 0 && sender.cap_kbps() > 0 && sender.refinements_yield())
        refine_one(options.refine_window_s, refine_s, true, written_seq);
      drop_prefetch();  // not taken (the keyframe did not qualify, or was not written): its thread ends here
    }
  });
  // Refinements while tracking: on their own thread, in the idle scheduling class (it gets a core only when the
  // tracker and the keyframes' reduction leave one), when no keyframe waits to be reduced or is being reduced and the
  // sender owes nothing (refinements included), sized to what crosses the line before the next keyframe's POST is
  // expected: the last keyframe's time + the keyframe interval + its reduction (mean + 2 deviations), less this
  // refinement's own reduction. A keyframe that comes sooner still goes first: the sender posts first revisions
  // before refinements, and at most the rest of a refinement's body (its window) is ahead of it on the line.
  std::thread refiner;
  std::atomic<pid_t> refiner_tid{0};
  if (options.refine_ceiling_kb > 0 && options.refine_while_tracking)
    refiner = std::thread([&] {
      refiner_tid = idle_this_thread();
      SmoothedDuration took(0.5);
      for (;;) {
        double free_s = 0;
        {
          std::unique_lock lock(mu);
          jobs_cv.wait_for(lock, std::chrono::milliseconds(50), [&] { return tracking_done; });
          if (tracking_done || should_stop()) return;
          if (!jobs.empty() || !deferred.empty() || reducing || holding || summary.keyframes == 0) continue;
          const double now_s = std::chrono::duration<double>(steady::now() - t_start).count();
          free_s = last_keyframe_s + interval.seconds() + reduce_s.value() - now_s - took.value();
        }
        // A refinement that yields to keyframes on the line need not end before the next one: its window is the
        // drain's.
        if (sender.refinements_yield()) free_s = options.refine_window_s;
        if (free_s <= 0 || sender.owed_s(true) > 0.05) continue;
        if (!refine_one(free_s, took, false)) {
          std::unique_lock lock(mu);  // nothing to refine at this window: wait for the next keyframe or answer
          jobs_cv.wait_for(lock, std::chrono::milliseconds(100), [&] { return tracking_done; });
        }
      }
    });
  auto finish_reductions = [&] {
    {
      std::lock_guard lock(mu);
      tracking_done = true;
    }
    jobs_cv.notify_all();
    if (reducer.joinable()) reducer.join();
    if (refiner_tid != 0) back_to_normal(refiner_tid);
    if (refiner.joinable()) refiner.join();
    tracking_done_for_refiner = true;
  };

  auto on_keyframe = [&](const RgbdFrame& frame, const FrameRecord& record) -> Status {
    if (summary.resumed && static_cast<int>(record.index) == summary.resumed_at_frame) return ok_status();
    KeyframeJob job;
    job.frame = frame;  // the images are shared (cv::Mat), not copied; nothing writes them
    job.frame_index = static_cast<int>(record.index);
    job.pose = anchor * record.pose;
    job.captured = captured;
    job.tracked = unix_now();
    {
      std::lock_guard lock(mu);
      last_keyframe_s = std::chrono::duration<double>(steady::now() - t_start).count();
      interval.on_keyframe(last_keyframe_s);
      jobs.push_back(std::move(job));
      summary.reduce_queue_max = std::max(summary.reduce_queue_max, jobs.size());
    }
    jobs_cv.notify_all();
    if (!options.realtime) {
      // As fast as it can: no camera to keep up with, so the tracker waits for the reduction instead of taking the
      // CPU it needs (but not while the keyframe is held back for the link: a newer one may supersede it).
      std::unique_lock lock(mu);
      jobs_cv.wait(lock, [&] { return holding || (jobs.empty() && !reducing) || should_stop(); });
    }
    return ok_status();
  };
  auto on_frame = [&](const FrameRecord& r, size_t done, size_t total) {
    if (frame_began) {  // this frame was read (not dropped)
      const double wall = std::chrono::duration<double, std::milli>(steady::now() - *frame_began).count();
      const double cpu = thread_cpu_ms() - frame_cpu_began;
      std::lock_guard lock(mu);
      summary.frame_wall_ms.push_back(wall);
      summary.frame_cpu_ms.push_back(cpu);
      summary.read_cpu_ms.push_back(frame_read_cpu_ms);
    }
    frame_began.reset();
    poll_cap();
    StreamProgress copy;
    {
      std::lock_guard lock(mu);
      progress.frames_done = done;
      progress.frames_total = total;
      progress.tracking = r.tracked ? (r.icp_used ? "tracked (ICP)" : "tracked") : r.message;
      copy = progress;
    }
    copy.sender = sender.stats();
    if (on_progress) on_progress(copy);
  };

  auto result = track_sequence(source.size(), load, params, on_keyframe, on_frame);
  if (camera) {
    camera->stop();
    summary.dropped = camera->dropped();
  }
  finish_reductions();
  if (!result) {
    sender.stop();
    return result.error();
  }
  summary.frames = result->frames.size();
  summary.tracked = result->tracked;

  // Drain: until the sender has nothing pending and no refinement is left to make, stops for good, or stop is asked.
  // The next refinement is reduced once the link owes no more than that takes, so it is ready when the line frees.
  progress.draining = true;
  for (;;) {
    poll_cap();
    progress.sender = sender.stats();
    if (on_progress) on_progress(progress);
    if (!progress.sender.fatal.empty()) break;
    if (should_stop()) {
      summary.stopped = true;
      break;
    }
    if (sender.owed_s(true) <= std::max(refine_s.value(), 0.1) && refine_one(options.refine_window_s, refine_s, true))
      continue;
    if (sender.stats().pending == 0) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  sender.stop();
  summary.sender = sender.stats();
  summary.deferred_waiting = outbox.deferred().size();
  summary.stopped = summary.stopped || should_stop();
  summary.seconds = std::chrono::duration<double>(steady::now() - t_start).count();
  if (!summary.sender.fatal.empty()) return make_error(ErrorCode::kUnavailable, summary.sender.fatal);
  return summary;
}

}  // namespace rgbdcast::stream
