#pragma once
// The sender thread: takes keyframes from the outbox and posts them until the server has each one, within what the
// link carries.
//
// Order: the newest pending keyframe goes first (the operator's picture stays current); older ones follow, newest
// to oldest, when the link has room. Pacing: with a cap (--link-kbps), the next POST starts no earlier than
// bytes / cap after the previous one started, so the average rate never exceeds the cap even on a faster link.
// Failures: a POST without an answer, a 5xx or a 503/429 is retried after a backoff delay (stream/backoff.h), and
// lowers the link estimate (stream/link_estimator.h); the same bytes are re-posted, so a POST whose answer was lost
// is answered 200 by the server's idempotency on (mission, seq). A 409 is resolved by reading the mission back:
// when it holds this seq with the same byte count, it is acknowledged; otherwise the entry is rejected (counted as
// lost). Another 4xx rejects the entry. A 401/403 stops the sender (fatal): the token is wrong.
// Thread-safety: every public method may be called from any thread.
#include <condition_variable>
#include <functional>
#include <mutex>
#include <optional>
#include <random>
#include <set>
#include <string>
#include <thread>

#include "stream/backoff.h"
#include "stream/link_estimator.h"
#include "stream/outbox.h"
#include "stream/uplink.h"

namespace rgbdcast::stream {

struct SenderParams {
  std::string mission;
  LinkEstimatorParams link;
  BackoffParams backoff;
  unsigned seed = 0;  // of the jitter; 0: from std::random_device
};

struct SenderStats {
  size_t acked = 0, rejected = 0, pending = 0;  // outbox entries
  size_t pending_bytes = 0;
  size_t acked_bytes = 0;     // acknowledged by this run
  size_t posts = 0, failures = 0;
  double estimate_kbps = 0;
  double cap_kbps = 0;        // the cap now (--link-kbps, or --link-kbps-file's last value); 0: none
  double busy_s = 0;          // seconds this run had a POST in flight
  bool link_down = false;     // the last attempt failed
  std::string last_error;     // of the last failed attempt
  std::string fatal;          // non-empty: the sender stopped for good
};

class Sender {
 public:
  Sender(Outbox& outbox, Uplink& uplink, const SenderParams& params);
  ~Sender();
  Sender(const Sender&) = delete;
  Sender& operator=(const Sender&) = delete;

  void start();
  void stop();    // returns once the thread ended (an in-flight POST finishes or times out first)
  void notify();  // a new entry is in the outbox
  // The producer takes a never-attempted entry out of the sender's reach (to coarsen it); false when it is being
  // sent or was attempted. release() gives it back.
  bool claim(int seq);
  void release(int seq);
  double estimate_kbps() const;
  // How long a keyframe waits in the outbox before its first POST starts (pacing, a POST in flight), smoothed
  // (EWMA, weight 0.3; 0 before the first): part of the overhead the latency rule subtracts (link_estimator.h).
  double queue_wait_s() const;
  size_t acknowledged_posts() const;  // samples of the link estimate so far (0: it is still the initial guess)
  void set_cap_kbps(double cap_kbps);
  SenderStats stats() const;

 private:
  void run();
  int pick_locked(std::chrono::steady_clock::time_point now) const;

  Outbox& outbox_;
  Uplink& uplink_;
  SenderParams params_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::thread thread_;
  bool stopping_ = false;
  LinkEstimator estimator_;
  Backoff backoff_;
  std::mt19937 rng_;
  std::set<int> claimed_;
  int in_flight_ = -1;
  std::chrono::steady_clock::time_point not_before_{};  // backoff or pacing
  std::optional<double> queue_wait_s_;
  SenderStats stats_;
};

}  // namespace rgbdcast::stream
