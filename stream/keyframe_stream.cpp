#include "stream/keyframe_stream.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>
#include <utility>

#include "base/stopwatch.h"
#include "keyframes/trajectory_io.h"
#include "stream/camera_reader.h"
#include "stream/thread_priority.h"

namespace rgbdcast::stream {

namespace {

// How often a wait that nothing else ends polls should_stop (a flag set by a signal handler, which cannot notify).
constexpr std::chrono::milliseconds kStopPollPeriod{50};

Eigen::Matrix4d tum_pose(const std::array<double, 7>& p) {
  return pose_from_tum(p[0], p[1], p[2], p[3], p[4], p[5], p[6]);
}

// A tracked keyframe on its way to the reduction thread.
struct KeyframeJob {
  RgbdFrame frame;
  int frame_index = 0;
  Eigen::Matrix4d pose;              // camera to world, in the mission's world
  double captured = 0, tracked = 0;  // Unix s, for the records
  // Its capture on the runtime's clock (CameraFrame::began_s), which its age is measured on; none for a resumed one
  // (captured by an earlier run: only its Unix time is known).
  std::optional<double> captured_s;
  bool resumed = false;  // a deferred keyframe reloaded from the outbox's records
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

// One run of run_stream: the threads (the caller's tracker, the camera reader, the reduction thread, the refiner,
// a refinement reduced beside the first keyframe), their queues and locks, and the summary. What to do is decided
// by stream/stream_policy.h from a snapshot taken here.
class StreamRun {
 public:
  StreamRun(const FrameSource& source, Outbox& outbox, Sender& sender, const StreamOptions& options,
            const std::function<void(const StreamProgress&)>& on_progress, const std::function<bool()>& should_stop)
      : source_(source),
        outbox_(outbox),
        sender_(sender),
        options_(options),
        on_progress_(on_progress),
        should_stop_(should_stop),
        clock_(sender.clock()),
        unix_s_(options.unix_s ? options.unix_s : unix_seconds_now),
        t_start_(clock_.now_s()),
        params_(options.sequence),
        queues_(options.max_deferred),
        planner_(RefineLimits{options.refine_ceiling_kb, options.refine_window_s, options.budget.headroom},
                 options.fine.above_kb) {}

  Result<StreamSummary> run();

 private:
  double since_start_s() const { return clock_.now_s() - t_start_; }
  LinkSnapshot link() const;
  void note_error(std::string message) {
    std::lock_guard lock(mu_);
    summary_.errors.push_back(std::move(message));
  }
  Result<RgbdFrame> read_frame(int frame_index);  // from the source, under source_mu_
  std::vector<CoverageView> earlier_than(int seq);
  FrameReductionOptions reduction_for(double budget_kb) const {
    return reduction_for_budget(options_.reduction, options_.fine, budget_kb);
  }
  void note_revision(int seq, const EncodedKeyframe& k, double budget_kb) {
    std::lock_guard lock(planner_mu_);
    planner_.note_revision(seq, k.glb.size(), budget_kb, k.fits);
  }
  void forget_tried(int seq) {
    std::lock_guard lock(planner_mu_);
    planner_.forget_tried(seq);
  }

  Status resume();
  void start_camera();
  Result<RgbdFrame> load(size_t i);
  void poll_cap();
  // The sender's on_change: a POST started or was answered, or the sender stopped (a lane's thread, no lock held).
  void link_changed() {
    {
      std::lock_guard lock(mu_);
      ++changes_;
    }
    jobs_cv_.notify_all();
  }

  // The reduction thread.
  void reducer_loop();
  bool hold_back(std::unique_lock<std::mutex>& lock, std::uint64_t seen);
  int reduce_keyframe(const KeyframeJob& job, bool was_deferred);
  int add_keyframe(const KeyframeJob& job, bool was_deferred, const EncodedKeyframe& encoded,
                   const KeyframeBudget& plan, double interval_s);
  void coarsen_backlog(int newest, double interval_s);
  void forget_deferred(int frame_index);
  void start_prefetch(const KeyframeJob& job, int seq, double budget_kb);
  void drop_prefetch();

  // Refinements: the refiner thread, the reduction thread right after the first keyframe, the drain.
  void refiner_loop();
  bool refine_one(double window_s, SmoothedDuration& took_s, bool ahead, int only_seq = -1);
  bool refine_chosen(double window_s, SmoothedDuration& took_s, bool ahead, int only_seq);  // refine_mu_ held
  std::optional<Result<EncodedKeyframe>> make_refinement(const RefineChoice& c, int only_seq, SmoothedDuration& took_s,
                                                         bool& beside_keyframe);
  bool add_refinement(const RefineChoice& c, const EncodedKeyframe& fine, bool beside_keyframe, double window_s,
                      int only_seq);
  bool await_answer(const RefineChoice& c, int only_seq);
  void count_refinement(bool made_ahead, bool beside_keyframe);

  // The tracker (the caller's thread) and the drain.
  Status on_keyframe(const RgbdFrame& frame, const FrameRecord& record);
  void on_frame(const FrameRecord& r, size_t done, size_t total);
  void finish_reductions();
  void drain();

  const FrameSource& source_;
  Outbox& outbox_;
  Sender& sender_;
  const StreamOptions& options_;
  const std::function<void(const StreamProgress&)>& on_progress_;
  const std::function<bool()>& should_stop_;
  Clock& clock_;  // the sender's
  std::function<double()> unix_s_;
  const double t_start_;

  std::mutex mu_;  // summary_, progress_, interval_, last_keyframe_s_, queues_, changes_ and the flags below
  // Notified after each change of what the threads wait for: a keyframe queued or taken, a reduction done, a hold,
  // the cap, the end of tracking, the sender's state (Sender::set_on_change). Each such change also counts in
  // changes_, under mu_, so that a thread that read the state outside mu_ waits only if nothing changed since.
  std::condition_variable jobs_cv_;
  std::uint64_t changes_ = 0;
  StreamSummary summary_;
  StreamProgress progress_;
  SequenceParams params_;
  KeyframeInterval interval_;
  double last_keyframe_s_ = 0;  // since t_start_: when the last keyframe was tracked
  KeyframeQueues<KeyframeJob> queues_;
  bool tracking_done_ = false, reducing_ = false, holding_ = false;
  SmoothedDuration reduce_s_{0.3};  // a keyframe's reduction time: mean + 2 deviations (read under mu_)
  SmoothedDuration refine_s_{0.5};  // a refinement's, in the drain and right after the first keyframe

  // Coverage views of the keyframes in the outbox, in seq order (the deltas' reference).
  struct View {
    int seq;
    CoverageView view;
  };
  std::mutex views_mu_;
  std::vector<View> views_;
  Eigen::Matrix4d anchor_ = Eigen::Matrix4d::Identity();

  std::mutex source_mu_;  // the reader's and the reduction thread's reads of the source
  std::optional<CameraReader> camera_;
  // Per frame read (the tracker's thread only): its capture time, when its work began, the reader's CPU time for it
  // and the tracker thread's CPU clock when the tracker took it.
  double captured_ = 0;
  std::optional<double> frame_began_s_;  // on clock_
  double frame_captured_s_ = 0;          // on clock_ (frame_began_s_ is reset once the frame's work is counted)
  double frame_read_cpu_ms_ = 0, frame_cpu_began_ = 0;
  size_t sender_lanes_ = 1;
  std::optional<CapFile> cap_file_;

  std::mutex planner_mu_;
  RefinementPlanner planner_;
  std::mutex refine_mu_;             // one refinement at a time
  bool refine_turned_away_ = false;  // (under mu_) refine_one found refine_mu_ held since the last one ended
  std::atomic<bool> tracking_done_for_refiner_{false};  // the drain's refinements are not counted as while tracking

  // The first keyframe's refinement, reduced beside the keyframe itself and taken by refine_one instead of reducing
  // it again. Only the reduction thread starts, takes and drops it.
  struct Prefetch {
    int seq = -1;
    double budget_kb = 0;
    std::thread thread;
    std::optional<Result<EncodedKeyframe>> result;
    double took_s = 0;
  };
  Prefetch prefetch_;

  std::thread reducer_, refiner_;
  std::atomic<pid_t> refiner_tid_{0};
};

LinkSnapshot StreamRun::link() const {
  LinkSnapshot l;
  l.line_kbps = sender_.line_kbps();
  l.post_fixed_s = sender_.post_fixed_s();
  l.cap_kbps = sender_.cap_kbps();
  l.lanes = sender_lanes_;
  l.acknowledged_posts = sender_.acknowledged_posts();
  l.queue_wait_s = sender_.queue_wait_s();
  l.refinements_yield = sender_.refinements_yield();
  l.link_down = sender_.stats().link_down;
  return l;
}

Result<RgbdFrame> StreamRun::read_frame(int frame_index) {
  std::lock_guard lock(source_mu_);
  auto f = source_.frame(static_cast<size_t>(frame_index));
  if (f) f->index = frame_index;
  return f;
}

std::vector<CoverageView> StreamRun::earlier_than(int seq) {
  std::lock_guard lock(views_mu_);
  std::vector<CoverageView> out;
  for (const View& v : views_)
    if (v.seq < seq) out.push_back(v.view);
  return out;
}

// The outbox's entries are reloaded as coverage views and its deferred records wait again as deferred keyframes;
// tracking restarts at plan_resume's frame, anchored at its pose.
Status StreamRun::resume() {
  const std::vector<OutboxEntry> existing = outbox_.entries();
  const std::vector<DeferredKeyframe> waiting = outbox_.deferred();  // by frame
  const ResumePlan plan = plan_resume(existing, waiting);
  if (!plan.resumed) return ok_status();
  summary_.resumed = true;
  summary_.resumed_entries = existing.size();
  summary_.resumed_deferred = waiting.size();
  summary_.resumed_at_frame = plan.at_frame;
  anchor_ = tum_pose(plan.anchor);
  params_.from = static_cast<size_t>(std::max(0, plan.at_frame));
  auto reload = [&](int frame_index, const std::string& what) -> Result<RgbdFrame> {
    auto f = read_frame(frame_index);
    if (!f)
      return make_error(ErrorCode::kNotFound, "resuming from the outbox: " + what + "'s frame " +
                                                  std::to_string(frame_index) +
                                                  " cannot be reloaded from the input: " + f.error().message);
    return f;
  };
  for (int seq : plan.view_seqs) {
    const OutboxEntry& e = *std::find_if(existing.begin(), existing.end(), [&](const auto& x) { return x.seq == seq; });
    auto f = reload(e.frame_index, "keyframe " + std::to_string(e.seq));
    if (!f) return f.error();
    views_.push_back({e.seq, {f->intrinsics, f->depth_m, tum_pose(e.pose)}});
  }
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
    queues_.push_deferred(std::move(job));
  }
  return ok_status();
}

// The camera: a reader thread one frame ahead of the tracker (at the frames' own times in realtime).
void StreamRun::start_camera() {
  CameraReaderOptions ro;
  ro.realtime = options_.realtime;
  ro.fps_without_timestamps = options_.fps_without_timestamps;
  ro.from = params_.from;
  ro.clock = &clock_;
  ro.unix_s = unix_s_;
  ro.last = source_.size() == 0 ? 0 : std::min(params_.to, source_.size() - 1);
  if (source_.size() > 0 && ro.from <= ro.last) camera_.emplace(source_, ro, source_mu_);
}

Result<RgbdFrame> StreamRun::load(size_t i) {
  if (should_stop_()) return make_error(ErrorCode::kUnavailable, "stopped");
  if (!camera_) return make_error(ErrorCode::kNotFound, "frame " + std::to_string(i) + " is not in the source");
  auto taken = camera_->take(i);
  if (!taken) return taken.error();
  captured_ = taken->captured;
  frame_began_s_ = frame_captured_s_ = taken->began_s;
  frame_read_cpu_ms_ = taken->read_cpu_ms;
  frame_cpu_began_ = thread_cpu_ms();
  return std::move(taken->frame);
}

// --link-kbps-file: a changed value becomes the cap at once (the next budget and the sender's pacing follow it).
void StreamRun::poll_cap() {
  if (!cap_file_) return;
  auto changed = cap_file_->poll();
  {
    std::lock_guard lock(mu_);
    if (!changed) {
      summary_.errors.push_back(changed.error().message);
      return;
    }
    if (!*changed) return;
    sender_.set_cap_kbps(**changed);
    ++summary_.cap_changes;
    ++changes_;
  }
  jobs_cv_.notify_all();  // what the link owes, and whether refinements yield, changed
}

// ---- The reduction thread -----------------------------------------------------------------------------------------

void StreamRun::reducer_loop() {
  renice_this_thread(options_.reduce_nice);
  for (;;) {
    std::unique_lock lock(mu_);
    // on_keyframe and finish_reductions notify; a stop ends tracking, which ends this wait (finish_reductions).
    jobs_cv_.wait(lock, [&] { return !queues_.empty() || tracking_done_; });
    // Stopped: queued keyframes never reached the outbox (a resumed run tracks their frames again); deferred ones
    // have their records beside it (a resumed run reduces them).
    if (should_stop_()) return;
    // Nothing to reduce and tracking is done. Between keyframes refinements wait for the drain (or the refiner
    // thread): one made here would delay the next keyframe's reduction, which the latency rule pays for in that
    // keyframe's bytes.
    if (queues_.empty()) return;
    std::uint64_t seen = changes_;  // before the link is read: a change after it ends the hold-back's wait
    lock.unlock();
    const bool hold = hold_keyframe(options_.supersede, sender_.owed_s(), reduce_s_.value());
    lock.lock();
    if (should_stop_()) return;
    if (hold) {
      if (!hold_back(lock, seen)) return;
      continue;
    }
    holding_ = false;
    auto next = queues_.take();
    reducing_ = true;
    lock.unlock();
    const int written_seq = reduce_keyframe(next->first, next->second);
    const bool written = written_seq >= 0;
    lock.lock();
    reducing_ = false;
    if (next->second && written) ++(next->first.resumed ? summary_.resumed_deferred_sent : summary_.deferred_sent);
    const bool idle = queues_.empty();
    ++changes_;
    lock.unlock();
    jobs_cv_.notify_all();
    // Before any answer, under a cap with refinements that yield: the keyframe just written (sized to the initial
    // estimate) is refined at once at the cap's budget and its refinement goes beside its first POST, so the line
    // carries it while that POST's answer is awaited. Only until the first answer: a keyframe tracked meanwhile
    // waits for it.
    if (refine_right_after_keyframe(link(), written, idle))
      refine_one(options_.refine_window_s, refine_s_, true, written_seq);
    drop_prefetch();  // not taken (the keyframe did not qualify, or was not written): its thread ends here
  }
}

// The link owes too much: a newer keyframe tracked meanwhile goes first, the older ones are deferred (their records
// written so that a stop does not lose them) and the oldest beyond max_deferred dropped. `lock` holds mu_ on entry
// and on return. False: the sender stopped for good, the link will not free. Then it waits for the link to have
// room or a keyframe to come: until a change after `seen` (changes_) or the clock reaches when the sender's paced
// line has drained enough (Sender::owed_falls_to) with nothing else changing.
bool StreamRun::hold_back(std::unique_lock<std::mutex>& lock, std::uint64_t seen) {
  lock.unlock();
  if (!sender_.stats().fatal.empty()) return false;
  const Clock::time_point room_at = sender_.owed_falls_to(room_owed_s(reduce_s_.value()));
  lock.lock();
  if (!holding_) {
    holding_ = true;
    ++changes_;
    ++seen;                 // its own change does not end its wait; one that came before still does
    jobs_cv_.notify_all();  // a tracker waiting for this reduction goes on (and may supersede it)
  }
  auto held = queues_.hold();
  summary_.superseded += held.deferred_now.size();
  summary_.deferred_dropped += held.dropped.size();
  if (!held.deferred_now.empty() || !held.dropped.empty()) {
    lock.unlock();  // file operations, outside mu_ (the tracker takes it on every frame)
    for (const KeyframeJob& job : held.deferred_now) {
      const DeferredKeyframe k = deferred_record(job);
      if (Status st = outbox_.defer(k); !st)
        note_error("deferred keyframe of frame " + std::to_string(k.frame_index) +
                   " not persisted (a stop loses it): " + st.error().message);
    }
    for (const KeyframeJob& job : held.dropped) forget_deferred(job.frame_index);
    lock.lock();
  }
  clock_.wait_until(lock, jobs_cv_, room_at, [&] { return changes_ != seen; });
  return true;
}

void StreamRun::forget_deferred(int frame_index) {
  if (Status st = outbox_.undefer(frame_index); !st) note_error(st.error().message);
}

// A keyframe's budget (plan_keyframe_budget), the one frame -> scene call, the outbox, the backlog rule. A deferred
// keyframe is coarsened, and its record goes once it is handled (Outbox::add removes it with the entry; a keyframe
// with nothing new or whose reduction failed leaves nothing to add; one whose outbox write failed keeps it, for a
// resumed run). Returns its seq once it reached the outbox, else -1.
int StreamRun::reduce_keyframe(const KeyframeJob& job, bool was_deferred) {
  KeyframeBudgetInput in;
  {
    std::lock_guard lock(mu_);
    in.interval_s = interval_.seconds();
    in.reduce_s = reduce_s_.value();
  }
  in.age_s = job.captured_s ? clock_.now_s() - *job.captured_s : unix_s_() - job.captured;
  in.deferred = was_deferred;
  const KeyframeBudget plan =
      plan_keyframe_budget(link(), in, options_.budget, options_.latency, options_.coarse_factor);
  const int seq = outbox_.next_seq();
  // The refinement right after the first keyframe (reducer_loop) is reduced here, beside the keyframe's own
  // reduction, on a thread niced below it, so that it is ready when the keyframe's body has crossed the line.
  if (prefetch_.seq < 0)
    if (auto ahead_kb = beside_keyframe_budget_kb(link(), planner_.limits(), plan.budget_kb, was_deferred))
      start_prefetch(job, seq, *ahead_kb);
  const double t0 = clock_.now_s();
  auto encoded = encode_keyframe(job.frame, reduction_for(plan.budget_kb), plan.budget_kb, job.pose, earlier_than(seq));
  const double took = clock_.now_s() - t0;
  {
    std::lock_guard lock(mu_);  // (the refiner reads reduce_s_ under mu_)
    reduce_s_.on_sample(took);
    summary_.reduce_ms.push_back(1000.0 * took);
  }
  if (!encoded) {
    if (was_deferred) forget_deferred(job.frame_index);
    std::lock_guard lock(mu_);
    if (encoded.error().code == ErrorCode::kEmpty) {
      ++summary_.covered;
      return -1;
    }
    ++summary_.failed;
    summary_.errors.push_back("frame " + std::to_string(job.frame_index) + ": " + encoded.error().message);
    return -1;
  }
  return add_keyframe(job, was_deferred, *encoded, plan, in.interval_s);
}

int StreamRun::add_keyframe(const KeyframeJob& job, bool was_deferred, const EncodedKeyframe& encoded,
                            const KeyframeBudget& plan, double interval_s) {
  OutboxEntry e;
  e.frame_index = job.frame_index;
  e.timestamp = job.frame.timestamp;
  e.pose = pose_to_tum(job.pose.data());
  e.captured = job.captured;
  e.budget_kb = plan.budget_kb;
  e.triangles = encoded.triangles;
  e.tracked = job.tracked;
  e.reduced = unix_s_();
  e.coarsened = was_deferred;
  auto added = outbox_.add(e, encoded.glb);
  if (!added) {
    std::lock_guard lock(mu_);
    ++summary_.failed;
    summary_.errors.push_back(added.error().message);
    return -1;
  }
  note_revision(added->seq, encoded, plan.budget_kb);
  {
    std::lock_guard views_lock(views_mu_);
    views_.push_back({added->seq, {job.frame.intrinsics, job.frame.depth_m, job.pose}});
  }
  {
    std::lock_guard lock(mu_);
    ++summary_.keyframes;
    progress_.keyframes = summary_.keyframes;
    progress_.budget_kb = plan.budget_kb;
    progress_.interval_s = interval_s;
    progress_.overhead_s = plan.overhead_s;
  }
  sender_.notify();
  coarsen_backlog(added->seq, interval_s);
  return added->seq;
}

// The backlog rule's coarsen step (CoarsenPlan): each chosen entry re-reduced once, kept when smaller.
void StreamRun::coarsen_backlog(int newest, double interval_s) {
  CoarsenPlan plan(outbox_.entries(), newest, sender_.estimate_kbps(), interval_s,
                   {options_.max_backlog_s, options_.coarse_factor, options_.budget.floor_kb});
  while (auto step = plan.next()) {
    if (!sender_.claim(step->seq)) continue;
    const auto e = outbox_.entry(step->seq);
    auto frame = e ? read_frame(e->frame_index) : Result<RgbdFrame>(make_error(ErrorCode::kNotFound, "gone"));
    if (frame) {
      auto coarse = encode_keyframe(*frame, reduction_for(step->target_kb), step->target_kb, tum_pose(e->pose),
                                    earlier_than(step->seq));
      if (coarse && coarse->glb.size() < e->bytes) {
        Status st = outbox_.coarsen(step->seq, coarse->glb, step->target_kb, coarse->triangles);
        std::lock_guard lock(mu_);
        if (st) {
          plan.shrunk_by(e->bytes - coarse->glb.size());
          ++summary_.coarsened;
        } else {
          summary_.errors.push_back(st.error().message);
        }
      }
    }
    sender_.release(step->seq);
  }
}

void StreamRun::start_prefetch(const KeyframeJob& job, int seq, double budget_kb) {
  prefetch_.seq = seq;
  prefetch_.budget_kb = budget_kb;
  prefetch_.thread = std::thread(
      [this, frame = job.frame, pose = job.pose, views = earlier_than(seq), nice = std::max(1, options_.reduce_nice)] {
        renice_this_thread(nice);
        const double t0 = clock_.now_s();
        prefetch_.result = encode_keyframe(frame, reduction_for(prefetch_.budget_kb), prefetch_.budget_kb, pose, views);
        prefetch_.took_s = clock_.now_s() - t0;
      });
}

void StreamRun::drop_prefetch() {
  if (prefetch_.thread.joinable()) prefetch_.thread.join();
  prefetch_ = Prefetch{};
}

// ---- Refinements --------------------------------------------------------------------------------------------------

// While tracking, in the idle scheduling class: when no keyframe waits or is being reduced and the sender owes
// nothing (refinements included), one refinement sized to refiner_window_s. A turn that made none waits for what
// it read to change (changes_: a keyframe, a reduction, a hold, an answer or POST of the sender, the end of
// tracking) or for the clock to reach when the sender's paced line owes little enough. Time alone does not open a
// window (refiner_window_s only shrinks with it) nor qualify a keyframe.
void StreamRun::refiner_loop() {
  refiner_tid_ = idle_this_thread();
  SmoothedDuration took(0.5);
  for (;;) {
    RefinerTurn turn;
    std::uint64_t seen = 0;
    {
      std::lock_guard lock(mu_);
      if (tracking_done_ || should_stop_()) return;
      seen = changes_;  // before anything is read: a change after it ends this turn's wait
    }
    const LinkSnapshot l = link();
    {
      std::lock_guard lock(mu_);
      turn.keyframe_work = !queues_.empty() || reducing_ || holding_;
      turn.keyframes = summary_.keyframes;
      turn.window_s = refiner_window_s(l, options_.refine_window_s, last_keyframe_s_, interval_.seconds(),
                                       reduce_s_.value(), took.value(), since_start_s());
    }
    turn.owed_s = sender_.owed_s(true);
    if (refiner_may_refine(turn) && refine_one(turn.window_s, took, false)) continue;
    const Clock::time_point room_at =
        turn.owed_s > kRefinerOwedS ? sender_.owed_falls_to(kRefinerOwedS, true) : Clock::kNever;
    std::unique_lock lock(mu_);
    clock_.wait_until(lock, jobs_cv_, room_at, [&] { return tracking_done_ || changes_ != seen; });
  }
}

// The refinement planner's choice, reduced (or taken from the prefetch) and added as the next revision when
// judge_refinement keeps it. Returns false when no keyframe qualifies (or another thread is refining); true when
// one was handled, kept or not. One at a time (refine_mu_): a thread turned away waits for a change, so the one
// refining counts one (changes_) when it is done, whether or not its refinement reached the sender.
bool StreamRun::refine_one(double window_s, SmoothedDuration& took_s, bool ahead, int only_seq) {
  if (!(options_.refine_ceiling_kb > 0)) return false;
  // Turning away and marking it, and ending and reading the mark, are each one step under mu_, so no mark is missed.
  std::unique_lock refining(refine_mu_, std::defer_lock);
  {
    std::lock_guard lock(mu_);
    if (!refining.try_lock()) {
      refine_turned_away_ = true;
      return false;
    }
  }
  const bool handled = refine_chosen(window_s, took_s, ahead, only_seq);
  bool wake = false;
  {
    std::lock_guard lock(mu_);
    refining.unlock();
    wake = std::exchange(refine_turned_away_, false);
    if (wake) ++changes_;
  }
  if (wake) jobs_cv_.notify_all();
  return handled;
}

bool StreamRun::refine_chosen(double window_s, SmoothedDuration& took_s, bool ahead, int only_seq) {
  const std::vector<OutboxEntry> all = outbox_.entries();
  RefinementPlanner::Result choice;
  {
    std::lock_guard lock(planner_mu_);
    choice = planner_.choose(all, link(), {window_s, ahead, only_seq});
  }
  if (choice.newly_saturated > 0) {
    std::lock_guard lock(mu_);
    summary_.refine_saturated += choice.newly_saturated;
  }
  if (!choice.chosen) return false;
  bool beside_keyframe = false;
  auto fine = make_refinement(*choice.chosen, only_seq, took_s, beside_keyframe);
  if (!fine || !*fine) return true;
  return add_refinement(*choice.chosen, **fine, beside_keyframe, window_s, only_seq);
}

// Reduced already beside the keyframe (the reduction thread's first keyframe), or reduced now from its frame.
// Nothing when the frame cannot be read (the error is in the summary).
std::optional<Result<EncodedKeyframe>> StreamRun::make_refinement(const RefineChoice& c, int only_seq,
                                                                  SmoothedDuration& took_s, bool& beside_keyframe) {
  std::optional<Result<EncodedKeyframe>> out;
  if (only_seq >= 0 && prefetch_.seq >= 0) {
    if (prefetch_.thread.joinable()) prefetch_.thread.join();
    if (prefetch_.seq == c.entry.seq && prefetch_.budget_kb == c.budget_kb && prefetch_.result) {
      out = std::move(prefetch_.result);
      took_s.on_sample(prefetch_.took_s);
      beside_keyframe = true;
    }
    prefetch_ = Prefetch{};
  }
  if (out) return out;
  auto frame = read_frame(c.entry.frame_index);
  if (!frame) {
    note_error("refining keyframe " + std::to_string(c.entry.seq) + ": " + frame.error().message);
    return std::nullopt;
  }
  const double t0 = clock_.now_s();
  out = encode_keyframe(*frame, reduction_for(c.budget_kb), c.budget_kb, tum_pose(c.entry.pose),
                        earlier_than(c.entry.seq));
  took_s.on_sample(clock_.now_s() - t0);
  return out;
}

void StreamRun::count_refinement(bool made_ahead, bool beside_keyframe) {
  std::lock_guard lock(mu_);
  ++summary_.refined;
  if (made_ahead) ++summary_.refined_ahead;
  if (beside_keyframe) ++summary_.refined_beside_keyframe;
  if (!tracking_done_for_refiner_) ++summary_.refined_while_tracking;
}

// Made ahead, the refinement waits for the answer to the revision it replaces (refinement_ahead_step). The
// reduction thread (only_seq >= 0) does not wait (the next keyframe would wait with it): the drain or the refiner
// thread makes the refinement again once the keyframe qualifies there. An outage is not worth holding the drain (its
// cap polls) for. True: answered, to be added.
bool StreamRun::await_answer(const RefineChoice& c, int only_seq) {
  const int seq = c.entry.seq, rev = c.entry.rev;
  const bool waits = only_seq < 0;
  std::optional<OutboxEntry> now = !waits && !c.entry.acked ? outbox_.entry(seq) : c.entry;
  for (;;) {
    AheadSnapshot s;
    s.now = std::move(now);
    s.rev = rev;
    s.waits = waits;
    if (waits && s.now && !s.now->acked) {
      const SenderStats stats = sender_.stats();
      s.stopping = should_stop_() || !stats.fatal.empty();
      s.link_down = stats.link_down;
    }
    switch (refinement_ahead_step(s)) {
      case AheadStep::kAdd:
        return true;
      case AheadStep::kDrop:
        return false;
      case AheadStep::kRedoLater:
        forget_tried(seq);
        return false;
      case AheadStep::kWait:
        break;
    }
    // The entry's answer, a POST failing (link_down) and the sender's stop wake it; the timeout is only the period
    // at which should_stop_ is polled.
    now = sender_.wait_entry(
        seq, [&](const auto& e) { return !e || !e->rejected.empty() || e->rev != rev || e->acked; }, kStopPollPeriod,
        s.link_down);
  }
}

bool StreamRun::add_refinement(const RefineChoice& c, const EncodedKeyframe& fine, bool beside_keyframe,
                               double window_s, int only_seq) {
  const int seq = c.entry.seq, rev = c.entry.rev;
  if (judge_refinement(fine.glb.size(), c.entry.bytes, false, false, 0) == RefinementVerdict::kTooSmall) {
    std::lock_guard lock(mu_);
    ++summary_.refined_not_kept;
    return true;
  }
  // From the cap, with refinements that yield: beside the first revision's POST if it is still out. Reduced beside
  // its keyframe, the refinement can be ready before a lane has taken the keyframe and marked it attempted (it reads
  // the GLB first, stream/sender.cpp): wait for that (a lane takes it at once when nothing else waits), not for the
  // answer. The lanes wake the wait; its 300 ms is a bound: a keyframe not started by then waits for pacing or a
  // lane, and the refinement then goes after its answer (await_answer).
  if (c.made_from_cap && sender_.refinements_yield()) {
    auto now = outbox_.entry(seq);
    if (beside_keyframe && !should_stop_())
      now = sender_.wait_entry(
          seq, [&](const auto& e) { return post_start_settled(e, rev); }, std::chrono::milliseconds(300));
    if (revise_beside_post(now, rev) && outbox_.revise_in_flight(seq, fine.glb, c.budget_kb, fine.triangles)) {
      note_revision(seq, fine, c.budget_kb);
      count_refinement(true, beside_keyframe);
      sender_.notify();
      return true;
    }
  }
  if (!await_answer(c, only_seq)) return true;
  // Sized to the cap before the link was measured: added only if the measured link carries it in the window;
  // otherwise the next call refines the keyframe at the measured budget (as without a cap).
  const double measured_kb = carried_kb(planner_.limits(), window_s, sender_.line_kbps(), sender_.post_fixed_s());
  if (judge_refinement(fine.glb.size(), c.entry.bytes, c.made_from_cap, true, measured_kb) ==
      RefinementVerdict::kRedoMeasured) {
    forget_tried(seq);
    std::lock_guard lock(mu_);
    ++summary_.refined_ahead_redone;
    return true;
  }
  Status st = outbox_.revise(seq, fine.glb, c.budget_kb, fine.triangles);
  if (st) {
    note_revision(seq, fine, c.budget_kb);
    count_refinement(c.made_ahead, beside_keyframe);
  } else {
    note_error(st.error().message);
  }
  sender_.notify();
  return true;
}

// ---- The tracker and the drain ------------------------------------------------------------------------------------

Status StreamRun::on_keyframe(const RgbdFrame& frame, const FrameRecord& record) {
  if (summary_.resumed && static_cast<int>(record.index) == summary_.resumed_at_frame) return ok_status();
  KeyframeJob job;
  job.frame = frame;  // the images are shared (cv::Mat), not copied; nothing writes them
  job.frame_index = static_cast<int>(record.index);
  job.pose = anchor_ * record.pose;
  job.captured = captured_;
  job.captured_s = frame_captured_s_;
  job.tracked = unix_s_();
  {
    std::lock_guard lock(mu_);
    last_keyframe_s_ = since_start_s();
    interval_.on_keyframe(last_keyframe_s_);
    queues_.push(std::move(job));
    summary_.reduce_queue_max = std::max(summary_.reduce_queue_max, queues_.waiting());
    ++changes_;
  }
  jobs_cv_.notify_all();
  if (!options_.realtime) {
    // As fast as it can: no camera to keep up with, so the tracker waits for the reduction instead of taking the
    // CPU it needs (but not while the keyframe is held back for the link: a newer one may supersede it).
    std::unique_lock lock(mu_);
    jobs_cv_.wait(lock, [&] { return tracker_may_go_on(holding_, queues_.waiting(), reducing_) || should_stop_(); });
  }
  return ok_status();
}

void StreamRun::on_frame(const FrameRecord& r, size_t done, size_t total) {
  if (frame_began_s_) {  // this frame was read (not dropped)
    const double wall = 1000.0 * (clock_.now_s() - *frame_began_s_);
    const double cpu = thread_cpu_ms() - frame_cpu_began_;
    std::lock_guard lock(mu_);
    summary_.frame_wall_ms.push_back(wall);
    summary_.frame_cpu_ms.push_back(cpu);
    summary_.read_cpu_ms.push_back(frame_read_cpu_ms_);
  }
  frame_began_s_.reset();
  poll_cap();
  StreamProgress copy;
  {
    std::lock_guard lock(mu_);
    progress_.frames_done = done;
    progress_.frames_total = total;
    progress_.tracking = r.tracked ? (r.icp_used ? "tracked (ICP)" : "tracked") : r.message;
    copy = progress_;
  }
  copy.sender = sender_.stats();
  if (on_progress_) on_progress_(copy);
}

void StreamRun::finish_reductions() {
  {
    std::lock_guard lock(mu_);
    tracking_done_ = true;
    ++changes_;
  }
  jobs_cv_.notify_all();
  if (reducer_.joinable()) reducer_.join();
  if (refiner_tid_ != 0) back_to_normal(refiner_tid_);
  if (refiner_.joinable()) refiner_.join();
  tracking_done_for_refiner_ = true;
}

// Until the sender has nothing pending and no refinement is left to make, stops for good, or stop is asked. The
// next refinement is reduced once the link owes no more than that takes, so it is ready when the line frees.
void StreamRun::drain() {
  progress_.draining = true;
  for (;;) {
    poll_cap();
    progress_.sender = sender_.stats();
    if (on_progress_) on_progress_(progress_);
    if (!progress_.sender.fatal.empty()) break;
    if (should_stop_()) {
      summary_.stopped = true;
      break;
    }
    if (link_has_room(sender_.owed_s(true), refine_s_.value()) && refine_one(options_.refine_window_s, refine_s_, true))
      continue;
    if (sender_.stats().pending == 0) break;
    sender_.wait_delivered(std::chrono::milliseconds(20));  // the cap file and stop are polled at that period
  }
}

Result<StreamSummary> StreamRun::run() {
  if (Status st = resume(); !st) return st.error();
  sender_.set_on_change([this] { link_changed(); });
  sender_.start();
  start_camera();
  sender_lanes_ = sender_.stats().lanes;
  if (!options_.link_kbps_file.empty()) cap_file_.emplace(options_.link_kbps_file);
  poll_cap();
  {
    auto dropped = queues_.trim();  // resumed with a smaller max_deferred
    summary_.deferred_dropped += dropped.size();
    for (const KeyframeJob& job : dropped) forget_deferred(job.frame_index);
  }
  reducer_ = std::thread([this] { reducer_loop(); });
  if (options_.refine_ceiling_kb > 0 && options_.refine_while_tracking)
    refiner_ = std::thread([this] { refiner_loop(); });

  auto result = track_sequence(
      source_.size(), [this](size_t i) { return load(i); }, params_,
      [this](const RgbdFrame& f, const FrameRecord& r) { return on_keyframe(f, r); },
      [this](const FrameRecord& r, size_t done, size_t total) { on_frame(r, done, total); });
  if (camera_) {
    camera_->stop();
    summary_.dropped = camera_->dropped();
  }
  finish_reductions();
  if (!result) {
    sender_.stop();
    sender_.set_on_change(nullptr);
    return result.error();
  }
  summary_.frames = result->frames.size();
  summary_.tracked = result->tracked;
  drain();
  sender_.stop();
  sender_.set_on_change(nullptr);  // the lanes ended: none calls it any more
  summary_.sender = sender_.stats();
  summary_.deferred_waiting = outbox_.deferred().size();
  summary_.stopped = summary_.stopped || should_stop_();
  summary_.seconds = since_start_s();
  if (!summary_.sender.fatal.empty()) return make_error(ErrorCode::kUnavailable, summary_.sender.fatal);
  return summary_;
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

Result<StreamSummary> run_stream(const FrameSource& source, Outbox& outbox, Sender& sender,
                                 const StreamOptions& options,
                                 const std::function<void(const StreamProgress&)>& on_progress,
                                 const std::function<bool()>& should_stop) {
  StreamRun run(source, outbox, sender, options, on_progress, should_stop);
  return run.run();
}

}  // namespace rgbdcast::stream
