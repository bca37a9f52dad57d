#include "stream/link_estimator.h"

#include <algorithm>
#include <cmath>

namespace rgbdcast::stream {

Status LinkEstimatorParams::validate() const {
  auto finite_positive = [](double v) { return std::isfinite(v) && v > 0; };
  if (!std::isfinite(cap_kbps) || cap_kbps < 0)
    return make_error(ErrorCode::kInvalidArgument, "--link-kbps must be a finite number >= 0 (0: no cap)");
  if (!finite_positive(initial_kbps) || !finite_positive(floor_kbps))
    return make_error(ErrorCode::kInvalidArgument, "link estimator: initial and floor rates must be > 0");
  if (!(alpha > 0 && alpha <= 1) || !(alpha_down > 0 && alpha_down <= 1) || !(failure_factor > 0 && failure_factor <= 1))
    return make_error(ErrorCode::kInvalidArgument, "link estimator: alpha, alpha_down and failure_factor must be in (0, 1]");
  return ok_status();
}

LinkEstimator::LinkEstimator(const LinkEstimatorParams& params)
    : params_(params),
      average_kbps_(params.cap_kbps > 0 ? std::min(params.initial_kbps, params.cap_kbps) : params.initial_kbps) {}

void LinkEstimator::on_ack(size_t body_bytes, double seconds) {
  const double sample_kbps = static_cast<double>(body_bytes) * 8.0 / 1000.0 / std::max(seconds, 1e-3);
  // The first sample replaces the guess; later ones are averaged in.
  const double a = sample_kbps >= average_kbps_ ? params_.alpha : params_.alpha_down;
  average_kbps_ = samples_ == 0 ? sample_kbps : a * sample_kbps + (1.0 - a) * average_kbps_;
  average_kbps_ = std::max(average_kbps_, params_.floor_kbps);
  ++samples_;
}

void LinkEstimator::on_failure() {
  // From the capped value: a failure on a link far faster than the cap must still lower what is reported.
  average_kbps_ = std::max(estimate_kbps() * params_.failure_factor, params_.floor_kbps);
}

void LinkEstimator::set_cap_kbps(double cap_kbps) { params_.cap_kbps = std::max(0.0, cap_kbps); }

double LinkEstimator::estimate_kbps() const {
  return params_.cap_kbps > 0 ? std::min(average_kbps_, params_.cap_kbps) : average_kbps_;
}

KeyframeInterval::KeyframeInterval(double initial_s, double alpha, double min_s, double max_s)
    : initial_s_(initial_s), alpha_(alpha), min_s_(min_s), max_s_(max_s) {}

void KeyframeInterval::on_keyframe(double wall_time_s) {
  if (last_) {
    const double gap = std::clamp(wall_time_s - *last_, min_s_, max_s_);
    average_ = average_ ? alpha_ * gap + (1.0 - alpha_) * *average_ : gap;
  }
  last_ = wall_time_s;
}

double KeyframeInterval::seconds() const { return std::clamp(average_.value_or(initial_s_), min_s_, max_s_); }

double keyframe_budget_kb(double estimate_kbps, double interval_s, const BudgetRule& rule) {
  const double kb = estimate_kbps / 8.0 * interval_s * rule.headroom;  // kbit/s / 8 = kB/s
  if (!std::isfinite(kb)) return rule.floor_kb;
  return std::clamp(kb, rule.floor_kb, rule.ceiling_kb);
}

}  // namespace rgbdcast::stream
