#pragma once
// Retry delays after a failed POST: exponential (initial_s x factor^n), capped at max_s, with jitter so that
// senders that failed together do not retry together: each delay is drawn uniformly from [(1 - jitter) d, d].
// A server's Retry-After (503) raises the delay to at least that value (still capped at retry_after_max_s).
// Not thread-safe; the random source is the caller's (a seeded std::mt19937 in tests).
#include <random>

#include "scene/result.h"

namespace rgbdcast::stream {

struct BackoffParams {
  double initial_s = 0.2;
  double factor = 2.0;
  double max_s = 2.0;             // the longest gap between attempts, so a link that returns is noticed quickly
  double jitter = 0.5;            // fraction of the delay that is random
  double retry_after_max_s = 30;  // the most a server's Retry-After may ask for
  Status validate() const;
};

class Backoff {
 public:
  explicit Backoff(const BackoffParams& params) : params_(params) {}
  // The delay before the next attempt after one more failure; retry_after_s < 0 when the server gave none.
  double next_delay_s(std::mt19937& rng, double retry_after_s = -1);
  void reset() { failures_ = 0; }
  int failures() const { return failures_; }

 private:
  BackoffParams params_;
  int failures_ = 0;
};

}  // namespace rgbdcast::stream
