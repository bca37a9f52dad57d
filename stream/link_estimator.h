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
#include <string>

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

// A duration that varies (a keyframe's reduction time on a shared machine), smoothed as TCP smooths its round trip
// (RFC 6298): mean and mean deviation as EWMAs (weights 1/8 and 1/4); value() = mean + k x deviation, so that a
// budget planned with it still fits when the next sample is slower than usual (k = 2: aims near the p95, not the
// median). `initial_s` until the first sample.
class SmoothedDuration {
 public:
  explicit SmoothedDuration(double initial_s, double k = 2.0) : initial_s_(initial_s), k_(k) {}
  void on_sample(double seconds);
  double value() const;
  size_t samples() const { return samples_; }

 private:
  double initial_s_, k_;
  double mean_ = 0, deviation_ = 0;
  size_t samples_ = 0;
};

struct BudgetRule {
  double floor_kb = 4;      // smallest budget: below it a realtime keyframe is mostly its header and texture header
  double ceiling_kb = 40;   // the realtime preset's default budget: more buys little (BENCHMARKS: rate-distortion)
  double headroom = 0.9;    // leave 10 % for HTTP and TCP overhead
};

// estimate_kbps * 1000 / 8 bytes/s x interval_s x headroom, in kB, clamped to the rule's [floor_kb, ceiling_kb].
double keyframe_budget_kb(double estimate_kbps, double interval_s, const BudgetRule& rule = {});

// The latency rule (--latency-ms): a keyframe should be viewable on the service `target_s` after its capture. Of
// that, `overhead_s` goes before its POST starts (reading and tracking the frame, reducing it, waiting for the line:
// measured by the caller); the rest is for the POST. The estimate is the goodput of whole POSTs (body bytes over
// the seconds from the request's start to its answer, so round trip and server time are in it), so
// estimate x the rest is the byte count whose POST takes about that long; the rule is self-correcting: when the
// fixed cost per POST is large, smaller posts measure a lower goodput and the budget shrinks further, until a POST
// takes the time it was given. The POST's share never falls below `min_post_share` x target_s: when the overhead
// alone exceeds the target, a smaller keyframe cannot make it on time, and starving it would only cost quality.
// Returns estimate/8 x max(target_s - overhead_s, min_post_share x target_s) x headroom, in kB, clamped to the
// rule's [floor_kb, ceiling_kb]; target_s <= 0 turns the rule off (ceiling_kb).
struct LatencyRule {
  double target_s = 1.0;        // --latency-ms / 1000; 0: off
  double min_post_share = 0.25;
  // Before the first acknowledged POST the estimate is a guess of the line rate (--initial-kbps or the cap) without
  // the round trip and the server's time in it: the caller adds this much to the overhead until then.
  double first_post_fixed_s = 0.2;
};
double latency_budget_kb(double estimate_kbps, double overhead_s, const LatencyRule& latency,
                         const BudgetRule& rule = {});

// The budget of the next keyframe: the smaller of the rate rule (keyframe_budget_kb) and the latency rule.
double next_keyframe_budget_kb(double estimate_kbps, double interval_s, double overhead_s, const LatencyRule& latency,
                               const BudgetRule& rule = {});

// --link-kbps-file: a small control file holding the cap in kbit/s (one number, 0 = no cap), re-read while
// streaming so the cap can change without a restart (e.g. `echo 100 > FILE` when the radio reports a worse link).
// poll() reads the whole file (it is tiny) and reports a value only when the text changed since the last poll.
// Errors (the cap stays as it was): kInvalidInput when the text is not one finite number >= 0; a missing or
// unreadable file is not an error (nullopt: nothing to change), so the file may be created later.
class CapFile {
 public:
  explicit CapFile(std::string path) : path_(std::move(path)) {}
  Result<std::optional<double>> poll();
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::optional<std::string> last_text_;
};

}  // namespace rgbdcast::stream
