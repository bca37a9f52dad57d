#pragma once
// The uplink's rate as the sender learns it, and the byte budget of the next keyframe that follows from it.
//
// Estimate: an exponentially weighted moving average (EWMA) of the goodput of each acknowledged POST, i.e. the body
// bytes divided by the seconds from the request's start to the server's answer (so it includes the round trip and the
// server's own time: it is what the link actually delivers to an operator, not the raw line rate). A new sample has
// weight `alpha` when it is above the average and `alpha_down` when below (a degrading link is
// followed faster than a recovering one, as congestion control does). Each failed attempt (timeout, connection error, 5xx) multiplies the estimate by `failure_factor`,
// so that a dead link quickly asks for small keyframes; the first acknowledged samples after it raise it again. The
// estimate never falls below floor_kbps and what it reports never exceeds the cap (--link-kbps): the raw average
// is kept uncapped, so a cap that is raised again takes effect at once.
//
// Budget per keyframe: estimate (bytes/s) x the keyframe interval (s) x headroom, clamped to [floor_kb, ceiling_kb]:
// a keyframe should be carried before the next one is due. The interval is an EWMA of the wall time between
// keyframes (KeyframeInterval). Not thread-safe: the owner (stream/sender.h) guards it.
#include <cstddef>
#include <optional>

#include "scene/result.h"

namespace rgbdcast::stream {

struct LinkEstimatorParams {
  double cap_kbps = 0;          // --link-kbps; 0 = no cap
  double initial_kbps = 500;    // before the first acknowledgement (the cap instead, when it is lower)
  double alpha = 0.3;           // weight of a new sample above the average
  double alpha_down = 0.5;      // weight of a new sample below it
  double failure_factor = 0.5;  // each failed attempt multiplies the estimate by this
  double floor_kbps = 8;        // the estimate never goes below
  Status validate() const;
};

class LinkEstimator {
 public:
  explicit LinkEstimator(const LinkEstimatorParams& params);
  // A POST of body_bytes acknowledged `seconds` after it started (seconds > 0; smaller values are clamped to 1 ms).
  void on_ack(size_t body_bytes, double seconds);
  void on_failure();
  void set_cap_kbps(double cap_kbps);  // 0 = no cap
  double cap_kbps() const { return params_.cap_kbps; }
  double estimate_kbps() const;        // kbit/s (1000 bit), capped
  size_t samples() const { return samples_; }

 private:
  LinkEstimatorParams params_;
  double average_kbps_;
  size_t samples_ = 0;
};

// The wall time between keyframes, smoothed (EWMA, weight alpha); `initial_s` until two keyframes were seen, and
// clamped to [min_s, max_s] so that a stall or a burst does not swing the budget to an extreme.
class KeyframeInterval {
 public:
  explicit KeyframeInterval(double initial_s = 1.0, double alpha = 0.3, double min_s = 0.25, double max_s = 5.0);
  void on_keyframe(double wall_time_s);
  double seconds() const;

 private:
  double initial_s_, alpha_, min_s_, max_s_;
  std::optional<double> last_, average_;
};

struct BudgetRule {
  double floor_kb = 4;      // smallest budget: below it a realtime keyframe is mostly its header and texture header
  double ceiling_kb = 40;   // the realtime preset's default budget: more buys little (BENCHMARKS: rate-distortion)
  double headroom = 0.9;    // leave 10 % for HTTP and TCP overhead
};

// estimate_kbps * 1000 / 8 bytes/s x interval_s x headroom, in kB, clamped to the rule's [floor_kb, ceiling_kb].
double keyframe_budget_kb(double estimate_kbps, double interval_s, const BudgetRule& rule = {});

}  // namespace rgbdcast::stream
