#pragma once
// The sender thread: takes keyframes from the outbox and posts them until the server has each one, within what the
// link carries.
//
// Order: the newest pending keyframe goes first (the operator's picture stays current); older ones follow, newest
// to oldest, when the link has room. "Newest" is by capture time, then seq (after an outage the keyframes held back
// get higher seqs than the newer one reduced first). A first revision (rev 0) goes before any refinement (rev > 0).
// Lanes: one thread per Uplink (each its own keep-alive connection), so up to that many POSTs are in flight; a
// second POST starts only when another entry is pending, while the first one's answer (round trip + the server's
// time, about 0.15 s here) is still outstanding, so that the line does not sit idle during it. A revision is in
// flight on at most one lane at a time; a newer revision of an entry whose POST is out (Outbox::revise_in_flight)
// may go beside it, and each answer is kept for the revision it is about.
// Pacing: with a cap (--link-kbps), POST bodies are scheduled back to back on a virtual line at the cap: a POST
// starts no earlier than when the previous bodies would have crossed it at the cap (line_free += bytes / cap), so
// the rate never exceeds the cap even on a faster link, and with one lane it is the old rule (bytes / cap after the
// previous POST started). A refinement's body (rev > 0) is put on the line chunk by chunk as it is written
// (Uplink's ChunkGate, kBodyChunkBytes each): with two lanes or more, a chunk waits while a first revision is
// waiting to start, so a new keyframe goes ahead of the rest of a refinement instead of behind all of it. So a
// refinement may be as large as the link has room for, not only as large as the gap before the next keyframe, and
// the line carries it while keyframes' answers are awaited. One refinement's body is written at a time (two paused
// ones could hold both lanes), and with two lanes or more a refinement starts only when it leaves a lane free; a
// refinement that waited for another body is not a sample of the link estimate.
// Failures: a POST without an answer, a 5xx or a 503/429 is retried after a backoff delay (stream/backoff.h), and
// lowers the link estimate (stream/link_estimator.h); the same bytes are re-posted, so a POST whose answer was lost
// is answered 200 by the server's idempotency on (mission, seq, rev). A 409 is resolved by reading the mission back:
// when it holds this seq at this rev with the same byte count, or at a higher rev (this revision is stale: a newer
// one is stored), it is acknowledged; otherwise the entry is rejected (counted as lost). Another 4xx rejects the entry.
// A 401/403 stops the sender (fatal): the token is wrong. Thread-safety: every public method may be called from any
// thread.
#include <condition_variable>
#include <functional>
#include <mutex>
#include <optional>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "stream/backoff.h"
#include "stream/clock.h"
#include "stream/link_estimator.h"
#include "stream/outbox.h"
#include "stream/uplink.h"

namespace rgbdcast::stream {

struct SenderParams {
  std::string mission;
  LinkEstimatorParams link;
  BackoffParams backoff;
  unsigned seed = 0;  // of the jitter; 0: from std::random_device
  // First revisions in flight at most (0: one per lane). rgbdcast stream gives refinements a lane more than
  // --max-in-flight, so that a refinement being written never takes the lane a keyframe needs.
  size_t max_first_in_flight = 0;
  // The clock of the pacing, the backoff and the busy times (null: the system's); must outlive the sender.
  Clock* clock = nullptr;
  // The wall clock of the records (Unix s; empty: the system's): a POST's start (the entry's `attempted`, the post
  // log) and end. A keyframe's wait in the outbox (queue_wait_s) is its POST's start minus the entry's `reduced`, so
  // it must be the clock the producer stamps `reduced` with (StreamOptions::unix_s).
  std::function<double()> unix_s;
};

// One POST as the sender saw it (Unix s, SenderParams::unix_s), for a benchmark that wants the line's timeline
// (rgbdcast stream
// --post-log).
struct PostRecord {
  int seq = -1, rev = 0;
  size_t bytes = 0;
  double started = 0, ended = 0;  // the request's start; its answer (or failure)
  bool stored = false;            // acknowledged
};

struct SenderStats {
  size_t acked = 0, rejected = 0, pending = 0;  // outbox entries
  size_t pending_bytes = 0;
  size_t acked_bytes = 0;                              // acknowledged by this run (refinements included)
  size_t refinements_acked = 0, refinement_bytes = 0;  // of which revisions (rev > 0)
  size_t posts = 0, failures = 0;
  double estimate_kbps = 0;
  double line_kbps = 0, post_fixed_s = 0;  // the POST model (stream/link_estimator.h)
  double cap_kbps = 0;                     // the cap now (--link-kbps, or --link-kbps-file's last value); 0: none
  double busy_s = 0;     // seconds this run had at least one POST in flight (the union over the lanes)
  double overlap_s = 0;  // of which seconds with two or more in flight
  size_t lanes = 1;
  bool link_down = false;  // the last attempt failed
  std::string last_error;  // of the last failed attempt
  std::string fatal;       // non-empty: the sender stopped for good
};

// The wait for a POST's answer: 3 s plus 4 x the transfer time of `bytes` at the estimate, but not at an estimate
// that failures pushed below 64 kbit/s (after an outage a blackholed request must be given up on within seconds);
// at most 60 s.
double answer_timeout_s(size_t bytes, double estimate_kbps);
// A POST answered 409 (the mission has seq with other bytes): the keyframe is ours from an earlier run whose answer
// was lost when mission_json (GET /missions/<id>) stores revision rev of seq with these bytes, or a newer revision.
// Then: that keyframe's JSON, the answer's body; otherwise (or for JSON that is not a mission) nothing.
std::optional<std::string> stored_keyframe(const std::string& mission_json, int seq, int rev, size_t bytes);

class Sender {
 public:
  Sender(Outbox& outbox, Uplink& uplink, const SenderParams& params);  // one lane
  // One lane per uplink (at least one; each must be a different Uplink: an Uplink is not thread-safe).
  Sender(Outbox& outbox, std::vector<Uplink*> uplinks, const SenderParams& params);
  ~Sender();
  Sender(const Sender&) = delete;
  Sender& operator=(const Sender&) = delete;

  void start();
  void stop();    // returns once the lanes ended (in-flight POSTs finish or time out first)
  void notify();  // the outbox changed (a new entry or revision): the lanes look for a POST to start
  // Called (on a lane's thread, no lock of the sender held) after each change of what owed_s(), idle(), stats() and
  // the outbox's entries report: a POST started or was marked attempted, an answer or failure came, the sender
  // stopped. Set before start(); it must not call set_on_change.
  void set_on_change(std::function<void()> on_change);
  // The producer takes a never-attempted entry out of the sender's reach (to coarsen it); false when it is being
  // sent or was attempted. release() gives it back.
  bool claim(int seq);
  void release(int seq);
  double estimate_kbps() const;
  // How long a keyframe waits in the outbox before its first POST starts (pacing, a POST in flight), smoothed
  // (EWMA, weight 0.3; 0 before the first; first revisions only): part of the overhead the latency rule subtracts
  // (link_estimator.h).
  double queue_wait_s() const;
  size_t acknowledged_posts() const;  // samples of the link estimate so far (0: it is still the initial guess)
  // Seconds until what is pending would be across the link: with a cap, the time left on the paced virtual line
  // plus the pending entries not yet started at the estimate; without, every pending byte at the estimate.
  // Refinements not yet started count only with include_refinements: a new keyframe goes before them.
  double owed_s(bool include_refinements = false) const;
  // When owed_s(include_refinements) falls to s if nothing but time changes (the paced line drains at one second
  // per second; pending bytes leave only with a change, which on_change reports); Clock::kNever when time alone
  // never brings it there. A wait for the link to have room sleeps until then or the next change.
  Clock::time_point owed_falls_to(double s, bool include_refinements = false) const;
  // The link estimator's POST model (stream/link_estimator.h): line rate (kbit/s) and fixed cost per POST (s).
  double line_kbps() const;
  double post_fixed_s() const;
  // Nothing pending and nothing in flight: the link is idle (a refinement may use it).
  bool idle() const;
  // A refinement's body yields to first revisions (a cap, and two lanes or more): a new keyframe waits for at most a
  // chunk of it (kBodyChunkBytes at the cap), or a round trip when every lane is busy, not for the whole body.
  bool refinements_yield() const;
  void set_cap_kbps(double cap_kbps);
  double cap_kbps() const;  // the cap now; 0: none
  Clock& clock() const { return clock_; }
  SenderStats stats() const;
  std::vector<PostRecord> post_log() const;  // every POST of this run, in the order they ended
  // Waits at most `timeout` (on the sender's clock, as wait_delivered) until `done` holds for seq's outbox entry
  // (nullopt: there is none), the sender stops, or (given link_down_was) SenderStats::link_down differs from
  // link_down_was, and returns the entry as last read. The lanes wake it when they mark an entry attempted or
  // answered or a POST fails, so the producer need not poll.
  std::optional<OutboxEntry> wait_entry(int seq, const std::function<bool(const std::optional<OutboxEntry>&)>& done,
                                        std::chrono::milliseconds timeout,
                                        std::optional<bool> link_down_was = std::nullopt);
  // Waits at most `timeout` until no outbox entry is pending (each one answered: stored or rejected) or the sender
  // stops; true when none is pending. The lanes wake it as they answer, so a drain need not poll for that.
  // The timeouts are the callers' bounds, or the period at which they poll sources that cannot notify (a stop flag,
  // a cap file).
  bool wait_delivered(std::chrono::milliseconds timeout);

 private:
  void run(Uplink& uplink);
  // Waits for this lane's next POST (pacing, backoff, nothing to pick) and marks it in flight; nothing once the
  // sender stops. paced_chunks: a refinement's body under a cap, written through the chunk gate.
  std::optional<OutboxEntry> next_post(bool& paced_chunks);
  void note_queue_wait(const OutboxEntry& entry, double post_started);  // before the POST starts
  // A 409: the outcome becomes kStored (body: the stored keyframe), kRejected or kRetry.
  void resolve_conflict(Uplink& uplink, const OutboxEntry& entry, size_t bytes, PostResult& r);
  void record_post_locked(const OutboxEntry& entry, size_t bytes, double post_started, const PostResult& r);
  std::optional<OutboxEntry> pick_locked() const;
  // A pending rev 0 that no lane is posting and no backoff holds, with two lanes or more (see the .cpp).
  bool first_revision_waiting_locked() const;
  Clock::duration line_time(size_t bytes) const;  // at the cap (> 0); mu_ held
  // owed_s's two parts: the paced line's time left (first) and the pending bytes at the estimate (second); mu_ held.
  std::pair<double, double> owed_parts_locked(bool include_refinements) const;
  void changed();  // notifies the lanes and on_change_; no lock held
  void flight_begin_locked(int seq, int rev);
  void flight_end_locked(int seq, int rev);

  Outbox& outbox_;
  std::vector<Uplink*> uplinks_;
  SenderParams params_;
  Clock& clock_;
  std::function<double()> unix_s_;  // params_.unix_s or the system's
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::vector<std::thread> threads_;
  bool stopping_ = false;
  LinkEstimator estimator_;
  Backoff backoff_;
  std::mt19937 rng_;
  std::set<int> claimed_;
  std::set<std::pair<int, int>> in_flight_;  // (seq, rev) of the POSTs out
  std::function<void()> on_change_;
  Clock::time_point busy_since_{}, overlap_since_{};
  Clock::time_point retry_not_before_{};  // backoff
  Clock::time_point line_free_{};         // pacing: when the bodies posted so far are across
  // The refinement whose body is being written chunk by chunk (at most one: see pick_locked), under a cap.
  bool refinement_writing_ = false;
  int refinement_writer_ = -1;  // its seq
  size_t refinement_bytes_total_ = 0, refinement_left_bytes_ = 0;
  Clock::time_point own_line_end_{};  // where its last chunk ended on the virtual line
  std::optional<double> queue_wait_s_;
  SenderStats stats_;
  std::vector<PostRecord> post_log_;
};

}  // namespace rgbdcast::stream
