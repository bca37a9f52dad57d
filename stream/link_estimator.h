#pragma once
// The uplink's rate as the sender learns it, and the byte budget of the next keyframe that follows from it.
//
// Estimate: an exponentially weighted moving average (EWMA) of the goodput of each acknowledged POST, i.e. the body
// bytes divided by the seconds from the request's start to the server's answer (so it includes the round trip and the
// server's own time: it is what the link actually delivers to an operator, not the raw line rate). A new sample has
// weight `alpha` when it is above the average and `alpha_down` when below (a degrading link is
// followed faster than a recovering one, as congestion control does). Each failed attempt (timeout, connection error,
// 5xx) multiplies the estimate by `failure_factor`, so that a dead link quickly asks for small keyframes; the first
// acknowledged samples after it raise it again. The estimate never falls below floor_kbps and what it reports never
// exceeds the cap (--link-kbps): the raw average is kept uncapped, so a cap that is raised again takes effect at once.
//
// The POST model: besides the goodput, the estimator fits each acknowledged POST's seconds as
// fixed_s + bytes / line rate (PostCostModel below), so that the budgets can ask what a POST of N bytes will take,
// instead of diluting the line rate by the round trip and the server's time of small POSTs.
//
// Budget per keyframe: the line rate (bytes/s) x (the keyframe interval x headroom - the fixed cost per POST),
// clamped to [floor_kb, ceiling_kb]: a keyframe should be carried before the next one is due. The interval is an EWMA
// of the wall time between keyframes (KeyframeInterval). Not thread-safe: the owner (stream/sender.h) guards it.
#include <algorithm>
#include <cstddef>
#include <optional>
#include <string>

#include "scene/result.h"

namespace rgbdcast::stream {

// seconds = fixed_s + bytes / rate, fitted by exponentially weighted least squares over the acknowledged POSTs (each
// older sample's weight x `forget` per new one), so it follows a link that changes. The fit is used once the
// samples' sizes spread enough to separate the two terms (a weighted standard deviation of at least `min_spread` x
// their mean: keyframes of one size cannot tell a slow line from a long round trip); until then, and whenever the
// fit is implausible (slope <= 0, a negative or too large fixed cost), the last good fixed cost is kept (at first
// `initial_fixed_s`: 0, or a round trip measured before the first POST) and the rate is what is left: mean bytes /
// (mean seconds - fixed). The fixed cost stays within [0, max_fixed_s].
// A link that changes while the POSTs are of one size can move part of the change into the fixed cost (measured in
// tests/stream/test_link_budget.cpp: a true 0.15 s became 0.01 s); the model then still predicts the POSTs it sees,
// and errs toward the goodput rule of before (fixed cost 0), which is the conservative side.
class PostCostModel {
 public:
  explicit PostCostModel(double forget = 0.8, double min_spread = 0.15, double max_fixed_s = 2.0,
                         double initial_fixed_s = 0)
      : forget_(forget),
        min_spread_(min_spread),
        max_fixed_s_(max_fixed_s),
        fixed_s_(std::clamp(initial_fixed_s, 0.0, max_fixed_s)) {}
  void on_sample(size_t bytes, double seconds);
  bool empty() const { return w_ == 0; }
  bool fitted() const { return fitted_; }  // the last sample gave a usable fit
  double fixed_s() const { return fixed_s_; }
  double rate_bytes_per_s() const { return rate_; }  // 0 before the first sample

 private:
  double forget_, min_spread_, max_fixed_s_;
  double w_ = 0, sx_ = 0, sy_ = 0, sxx_ = 0, sxy_ = 0;
  double fixed_s_ = 0, rate_ = 0;
  bool fitted_ = false;
};

struct LinkEstimatorParams {
  double cap_kbps = 0;          // --link-kbps; 0 = no cap
  double initial_kbps = 500;    // before the first acknowledgement (the cap instead, when it is lower)
  double alpha = 0.3;           // weight of a new sample above the average
  double alpha_down = 0.5;      // weight of a new sample below it
  double failure_factor = 0.5;  // each failed attempt multiplies the estimate by this
  double floor_kbps = 8;        // the estimate never goes below
  // The POST model's fixed cost before it can be fitted (PostCostModel): 0, or the round trip of a request without
  // a body measured before the first POST (rgbdcast stream: GET /healthz on the open connection), so that the first
  // acknowledged POST already gives a line rate instead of a goodput diluted by its round trip.
  double initial_fixed_s = 0;
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
  double estimate_kbps() const;  // goodput of whole POSTs, kbit/s (1000 bit), capped
  size_t samples() const { return samples_; }
  // The POST model's line rate (kbit/s, capped, lowered by failures as the goodput is) and fixed cost per POST (s).
  // Until the model is fitted (see PostCostModel) the line rate is the goodput estimate and the fixed cost 0.
  double line_kbps() const;
  double post_fixed_s() const;

 private:
  LinkEstimatorParams params_;
  double average_kbps_;
  size_t samples_ = 0;
  PostCostModel model_;
  double failure_scale_ = 1.0;  // of the model's rate: x failure_factor per failure, / failure_factor per ack
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
  double floor_kb = 4;     // smallest budget: below it a realtime keyframe is mostly its header and texture header
  double ceiling_kb = 40;  // the realtime preset's default budget: more buys little (BENCHMARKS: rate-distortion)
  double headroom = 0.9;   // leave 10 % for HTTP and TCP overhead
};

// rate_kbps * 1000 / 8 bytes/s x (interval_s x headroom - fixed_s), in kB, clamped to the rule's [floor_kb,
// ceiling_kb]. With fixed_s = 0 and the goodput as the rate, the rule of before the POST model.
double keyframe_budget_kb(double rate_kbps, double interval_s, const BudgetRule& rule = {}, double fixed_s = 0);

// The latency rule (--latency-ms): a keyframe should be viewable on the service `target_s` after its capture. Of
// that, `overhead_s` goes before its POST starts (reading and tracking the frame, reducing it, waiting for the line:
// measured by the caller); the rest is for the POST. The estimate is the goodput of whole POSTs (body bytes over
// the seconds from the request's start to its answer, so round trip and server time are in it), so
// estimate x the rest is the byte count whose POST takes about that long; the rule is self-correcting: when the
// fixed cost per POST is large, smaller posts measure a lower goodput and the budget shrinks further, until a POST
// takes the time it was given. The POST's share never falls below `min_post_share` x target_s: when the overhead
// alone exceeds the target, a smaller keyframe cannot make it on time, and starving it would only cost quality.
// Returns estimate/8 x max(target_s - overhead_s, min_post_share x target_s) x headroom, in kB, clamped to the
// rule's [floor_kb, ceiling_kb]; target_s <= 0 turns the rule off (ceiling_kb). With the POST model (a line rate
// and its fixed cost per POST fixed_s > 0) the POST's time is fixed_s + bytes / rate, so the bytes are
// rate/8 x (max(...) x headroom - fixed_s): the fixed point the goodput rule converges to, from the first keyframe.
struct LatencyRule {
  double target_s = 1.0;  // --latency-ms / 1000; 0: off
  double min_post_share = 0.25;
  // Before the first acknowledged POST the estimate is a guess of the line rate (--initial-kbps or the cap) without
  // the round trip and the server's time in it: the caller adds this much to the overhead until then.
  double first_post_fixed_s = 0.2;
};
double latency_budget_kb(double estimate_kbps, double overhead_s, const LatencyRule& latency,
                         const BudgetRule& rule = {}, double fixed_s = 0);

// The budget of the next keyframe: the smaller of the rate rule (keyframe_budget_kb) and the latency rule.
double next_keyframe_budget_kb(double estimate_kbps, double interval_s, double overhead_s, const LatencyRule& latency,
                               const BudgetRule& rule = {}, double fixed_s = 0);

// Refinements (stream/keyframe_stream.h): what a POST may carry in `window_s` seconds of an idle link:
// rate/8 x (window_s x headroom - fixed_s), in kB, at most ceiling_kb; 0 when that is not positive.
double refinement_budget_kb(double rate_kbps, double window_s, double fixed_s, double ceiling_kb,
                            double headroom = 0.9);

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
