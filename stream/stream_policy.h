#pragma once
// The stream's decisions (docs/streaming.md), each a pure function or a small state object fed with a snapshot:
// what is queued, what the link did, what time it is. They read no clock, start no thread and take no lock; the
// runtime (stream/keyframe_stream.cpp) takes the snapshot, calls them and applies what they return. Not
// thread-safe: the runtime serialises the calls on one object.
#include <array>
#include <cstddef>
#include <deque>
#include <map>
#include <optional>
#include <set>
#include <utility>
#include <vector>

#include "stream/link_estimator.h"
#include "stream/outbox.h"

namespace rgbdcast::stream {

// What the sender knows of the link at one moment (Sender's accessors).
struct LinkSnapshot {
  double line_kbps = 0, post_fixed_s = 0;  // the POST model
  double cap_kbps = 0;                     // 0: no cap
  size_t lanes = 1;
  size_t acknowledged_posts = 0;   // 0: the estimate is still the initial guess
  double queue_wait_s = 0;         // smoothed wait of a keyframe in the outbox
  bool refinements_yield = false;  // refinements yield to keyframes on the line (a cap, 2 lanes or more)
  bool link_down = false;
};

// ---- The budget planner -------------------------------------------------------------------------------------------

struct KeyframeBudgetInput {
  double interval_s = 1.0;  // the keyframe interval estimate
  double age_s = 0;         // seconds since the keyframe's capture, when its reduction starts
  double reduce_s = 0.3;    // the expected reduction time (SmoothedDuration)
  bool deferred = false;    // held back by the backlog rule: coarsened
};
struct KeyframeBudget {
  double budget_kb = 0;
  double overhead_s = 0;  // the latency rule's time before the POST
};
// The smaller of the rate rule and the latency rule; a deferred keyframe gets coarse_factor x the rate rule, not
// below the floor. With two lanes or more the rate rule counts no fixed cost per POST (the round trip overlaps the
// next body); the latency rule always does, and before any answer adds latency.first_post_fixed_s.
KeyframeBudget plan_keyframe_budget(const LinkSnapshot& link, const KeyframeBudgetInput& in, const BudgetRule& rule,
                                    const LatencyRule& latency, double coarse_factor);

// What a POST carries in window_s at line_kbps (refinement_budget_kb with the refinement's ceiling and headroom).
struct RefineLimits {
  double ceiling_kb = 200;  // 0: no refinements
  double window_s = 1.0;    // the longest window
  double headroom = 0.9;
};
double carried_kb(const RefineLimits& limits, double window_s, double line_kbps, double fixed_s);

// The budget of a refinement to reduce beside a keyframe about to be reduced at keyframe_kb (the first keyframe,
// before any answer, under a cap with refinements that yield): what the cap carries in the window, when that beats
// the keyframe's budget by 1.25 x and 8 kB; nothing otherwise.
std::optional<double> beside_keyframe_budget_kb(const LinkSnapshot& link, const RefineLimits& limits,
                                                double keyframe_kb, bool deferred);
// After a keyframe was written with nothing else queued: refine it at once (its revision goes beside its POST).
bool refine_right_after_keyframe(const LinkSnapshot& link, bool written, bool queues_empty);

// ---- The backlog rule ---------------------------------------------------------------------------------------------

// The link has room for work expected to take expected_s when it owes no more than that (at least 0.1 s): done any
// earlier, the work would only wait for the line. room_owed_s: that most it may owe.
double room_owed_s(double expected_s);
bool link_has_room(double owed_s, double expected_s);
// Hold the next keyframe back (newest first, older ones deferred): supersede is on and the link has no room.
bool hold_keyframe(bool supersede, double owed_s, double reduce_s);

// Without realtime the tracker waits for the reduction instead of taking the CPU it needs (no camera to keep up
// with): it goes on once no keyframe waits or is being reduced, or while one is held back for the link (a newer one
// may supersede it).
bool tracker_may_go_on(bool holding, size_t keyframes_waiting, bool reducing);

// Tracked keyframes waiting for the reduction thread, and the deferred ones. Job is the runtime's keyframe job (any
// copyable type; the tests use small structs).
template <class Job>
class KeyframeQueues {
 public:
  explicit KeyframeQueues(size_t max_deferred) : max_deferred_(max_deferred) {}
  void push(Job job) { jobs_.push_back(std::move(job)); }
  void push_deferred(Job job) { deferred_.push_back(std::move(job)); }  // oldest first (resumed records)
  bool empty() const { return jobs_.empty() && deferred_.empty(); }
  size_t waiting() const { return jobs_.size(); }
  size_t deferred() const { return deferred_.size(); }

  struct Held {
    std::vector<Job> deferred_now;  // superseded by a newer keyframe: their records are to be written
    std::vector<Job> dropped;       // beyond max_deferred, oldest first: their records are to be removed
  };
  // The link has no room: every waiting keyframe but the newest is deferred, and the oldest deferred beyond
  // max_deferred are dropped.
  Held hold() {
    Held out;
    while (jobs_.size() > 1) {
      out.deferred_now.push_back(jobs_.front());
      deferred_.push_back(std::move(jobs_.front()));
      jobs_.pop_front();
    }
    out.dropped = trim();
    return out;
  }
  // The oldest deferred beyond max_deferred, removed.
  std::vector<Job> trim() {
    std::vector<Job> dropped;
    while (deferred_.size() > max_deferred_) {
      dropped.push_back(std::move(deferred_.front()));
      deferred_.pop_front();
    }
    return dropped;
  }
  // The next keyframe to reduce once the link has room: the waiting ones in order, then the newest deferred.
  // second: it was deferred.
  std::optional<std::pair<Job, bool>> take() {
    if (!jobs_.empty()) {
      std::pair<Job, bool> out{std::move(jobs_.front()), false};
      jobs_.pop_front();
      return out;
    }
    if (deferred_.empty()) return std::nullopt;
    std::pair<Job, bool> out{std::move(deferred_.back()), true};
    deferred_.pop_back();
    return out;
  }

 private:
  size_t max_deferred_;
  std::deque<Job> jobs_, deferred_;
};

// The coarsen step: when the pending first revisions need more than max(max_backlog_s, 2 x interval) at the
// estimate, the older never-attempted keyframes are coarsened, oldest first, until the backlog fits.
struct CoarsenRule {
  double max_backlog_s = 2.0;
  double coarse_factor = 0.25;
  double floor_kb = 4;
};
struct CoarsenStep {
  int seq = -1;
  double target_kb = 0;
};
class CoarsenPlan {
 public:
  // entries: the outbox in seq order; newest: the keyframe just added (never coarsened).
  CoarsenPlan(std::vector<OutboxEntry> entries, int newest, double estimate_kbps, double interval_s,
              const CoarsenRule& rule);
  double backlog_s() const;
  double limit_s() const { return limit_s_; }
  // The next entry to coarsen while the backlog does not fit; nothing when it fits or none is left.
  std::optional<CoarsenStep> next();
  // The step's entry was replaced by a GLB this many bytes smaller.
  void shrunk_by(size_t bytes);

 private:
  std::vector<OutboxEntry> entries_;
  int newest_;
  double estimate_kbps_, limit_s_;
  CoarsenRule rule_;
  double pending_bytes_ = 0;
  size_t at_ = 0;
};

// ---- The refinement planner ---------------------------------------------------------------------------------------

// A refinement replaces its keyframe only when its GLB has at least this many times the bytes (docs/streaming.md).
inline constexpr double kRefinementKeepRatio = 1.25;

struct RefineQuery {
  double window_s = 1.0;  // the time the refinement may take on the line (at most RefineLimits::window_s)
  bool ahead = false;     // a keyframe whose POST is out may be refined (its revision added once answered)
  int only_seq = -1;      // >= 0: that keyframe or none
};
struct RefineChoice {
  OutboxEntry entry;  // the keyframe's entry as the snapshot had it
  double budget_kb = 0;
  bool made_ahead = false;     // its POST is not answered yet
  bool made_from_cap = false;  // sized to the cap before any answer measured the link
  size_t newly_saturated = 0;  // revisions found saturated for the first time (summary.refine_saturated)
};

// Remembers what was tried and which revisions fit their budget, and chooses the next refinement.
class RefinementPlanner {
 public:
  RefinementPlanner(RefineLimits limits, double fine_above_kb) : limits_(limits), fine_above_kb_(fine_above_kb) {}
  // The newest keyframe (by capture time, then seq) that qualifies: acknowledged ones first; then, with `ahead` and
  // the link not down, one whose POST is out, once an answer measured the link or under a cap (at the cap's
  // budget). A keyframe qualifies when the budget beats max(its budget, the last one tried) by 1.25 x and 8 kB and
  // its revision is not saturated at that budget. Records the choice's budget as tried. The returned choice may
  // carry newly_saturated > 0 with no entry: then `chosen` is false.
  struct Result {
    std::optional<RefineChoice> chosen;
    size_t newly_saturated = 0;
  };
  Result choose(const std::vector<OutboxEntry>& entries, const LinkSnapshot& link, const RefineQuery& query);
  // The refinement of seq is to be made again (dropped, or its keyframe's state changed): forget its budget.
  void forget_tried(int seq) { tried_.erase(seq); }
  // A revision of seq was written at budget_kb: remember whether its reduction fit (saturated below).
  void note_revision(int seq, size_t bytes, double budget_kb, bool fits);
  // Refining e at budget_kb can only give its GLB again: it fit its budget, and budget_kb has the same settings.
  bool saturated(const OutboxEntry& e, double budget_kb) const;
  const RefineLimits& limits() const { return limits_; }

 private:
  struct Fit {
    size_t bytes = 0;
    double budget_kb = 0;
  };
  RefineLimits limits_;
  double fine_above_kb_;
  std::map<int, double> tried_;                   // seq -> the largest budget a refinement of it was reduced at
  std::map<int, Fit> fits_;                       // seq -> its revision that fit
  std::set<std::pair<int, int>> saturated_seen_;  // (seq, rev) counted once
};

enum class RefinementVerdict {
  kKeep,          // add it as the next revision
  kTooSmall,      // under kRefinementKeepRatio x the bytes it replaces (refined_not_kept)
  kRedoMeasured,  // sized to the cap, more than the measured link carries in the window (refined_ahead_redone)
};
// A reduced refinement of `bytes` against the revision of `replaced_bytes`. measured_carried_kb: what the measured
// link carries in the window (checked only for one made from the cap, once its answer came).
RefinementVerdict judge_refinement(size_t bytes, size_t replaced_bytes, bool made_from_cap, bool answered,
                                   double measured_carried_kb);

// The refiner thread's window while tracking: refinements that yield get the whole window; otherwise what is left
// until the next keyframe's POST is expected (the last keyframe's time + the interval + its reduction, less this
// refinement's own reduction). Seconds; <= 0: not now.
double refiner_window_s(const LinkSnapshot& link, double window_s, double last_keyframe_s, double interval_s,
                        double reduce_s, double refine_s, double now_s);

// The refiner thread's turn while tracking. A refinement made while a keyframe waits, is being reduced or is held
// back would delay that keyframe; one made while the sender owes more than kRefinerOwedS (refinements included)
// would only wait for the line.
inline constexpr double kRefinerOwedS = 0.05;
struct RefinerTurn {
  bool keyframe_work = false;  // a keyframe waits for the reduction thread, is being reduced or is held back
  size_t keyframes = 0;        // written to the outbox by this run
  double window_s = 0;         // refiner_window_s
  double owed_s = 0;           // what the sender owes, refinements included
};
bool refiner_may_refine(const RefinerTurn& t);

// A refinement sized to the cap goes beside its keyframe's first POST (Outbox::revise_in_flight) when that revision
// is still the entry's, its POST has started and is not answered. The runtime may wait for the POST to start while
// post_start_settled is false (the entry is unchanged, pending and not yet attempted).
bool post_start_settled(const std::optional<OutboxEntry>& now, int rev);
bool revise_beside_post(const std::optional<OutboxEntry>& now, int rev);

// A refinement of revision `rev` made ahead (its POST out when it was chosen), as the entry changes.
enum class AheadStep {
  kAdd,        // the revision it replaces is answered: judge it against the measured link and add it
  kWait,       // not answered yet: wait for the answer and ask again
  kDrop,       // the entry was removed, rejected or revised meanwhile, or the run is stopping: nothing to add
  kRedoLater,  // not worth waiting for (an outage; a caller that does not wait): forget it, make it again later
};
struct AheadSnapshot {
  std::optional<OutboxEntry> now;  // the entry as the outbox has it
  int rev = 0;                     // the revision the refinement replaces
  bool waits = true;               // false: the reduction thread, which does not wait (the next keyframe would)
  bool stopping = false;           // stop was asked or the sender failed for good
  bool link_down = false;
};
AheadStep refinement_ahead_step(const AheadSnapshot& s);

// ---- Resume -------------------------------------------------------------------------------------------------------

struct ResumePlan {
  bool resumed = false;
  int at_frame = -1;  // tracking restarts at this frame (not tracked as a new keyframe again)
  std::array<double, 7> anchor{0, 0, 0, 0, 0, 0, 1};  // its camera-to-world pose, TUM order
  std::vector<int> view_seqs;  // entries whose frames are reloaded as coverage views (not rejected ones)
};
// From the outbox's entries (seq order) and deferred records (frame order): the latest keyframe's frame over both
// (a deferred keyframe reduced already may have a higher seq but an older frame, and a deferred record's frame may
// be the latest).
ResumePlan plan_resume(const std::vector<OutboxEntry>& entries, const std::vector<DeferredKeyframe>& deferred);

}  // namespace rgbdcast::stream
