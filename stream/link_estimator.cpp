#include "stream/link_estimator.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

namespace rgbdcast::stream {

Status LinkEstimatorParams::validate() const {
  auto finite_positive = [](double v) { return std::isfinite(v) && v > 0; };
  if (!std::isfinite(cap_kbps) || cap_kbps < 0)
    return make_error(ErrorCode::kInvalidArgument, "--link-kbps must be a finite number >= 0 (0: no cap)");
  if (!std::isfinite(initial_fixed_s) || initial_fixed_s < 0)
    return make_error(ErrorCode::kInvalidArgument, "link estimator: the initial fixed cost must be >= 0");
  if (!finite_positive(initial_kbps) || !finite_positive(floor_kbps))
    return make_error(ErrorCode::kInvalidArgument, "link estimator: initial and floor rates must be > 0");
  if (!(alpha > 0 && alpha <= 1) || !(alpha_down > 0 && alpha_down <= 1) ||
      !(failure_factor > 0 && failure_factor <= 1))
    return make_error(ErrorCode::kInvalidArgument,
                      "link estimator: alpha, alpha_down and failure_factor must be in (0, 1]");
  return ok_status();
}

LinkEstimator::LinkEstimator(const LinkEstimatorParams& params)
    : params_(params),
      average_kbps_(params.cap_kbps > 0 ? std::min(params.initial_kbps, params.cap_kbps) : params.initial_kbps),
      model_(0.8, 0.15, 2.0, params.initial_fixed_s) {}

void PostCostModel::on_sample(size_t bytes, double seconds) {
  if (!std::isfinite(seconds)) return;
  const double x = static_cast<double>(bytes), y = std::max(seconds, 1e-3);
  w_ = forget_ * w_ + 1;
  sx_ = forget_ * sx_ + x;
  sy_ = forget_ * sy_ + y;
  sxx_ = forget_ * sxx_ + x * x;
  sxy_ = forget_ * sxy_ + x * y;
  const double mx = sx_ / w_, my = sy_ / w_;
  const double var = std::max(0.0, sxx_ / w_ - mx * mx);
  fitted_ = false;
  if (var > 0 && std::sqrt(var) >= min_spread_ * mx) {
    const double slope = (sxy_ / w_ - mx * my) / var;  // s per byte
    const double fixed = my - slope * mx;
    if (slope > 0 && fixed >= 0 && fixed <= max_fixed_s_ && fixed < my) {
      fixed_s_ = fixed;
      rate_ = 1.0 / slope;
      fitted_ = true;
    }
  }
  if (!fitted_) {
    fixed_s_ = std::min(fixed_s_, 0.9 * my);  // what is left for the bytes must stay positive
    rate_ = mx / (my - fixed_s_);
  }
}

void LinkEstimator::on_ack(size_t body_bytes, double seconds) {
  model_.on_sample(body_bytes, seconds);
  failure_scale_ = std::min(1.0, failure_scale_ / params_.failure_factor);
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
  failure_scale_ *= params_.failure_factor;
}

double LinkEstimator::line_kbps() const {
  if (model_.empty()) return estimate_kbps();
  double kbps = std::max(model_.rate_bytes_per_s() * 8.0 / 1000.0 * failure_scale_, params_.floor_kbps);
  if (params_.cap_kbps > 0) kbps = std::min(kbps, params_.cap_kbps);
  return kbps;
}

double LinkEstimator::post_fixed_s() const { return model_.empty() ? 0.0 : model_.fixed_s(); }

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

double keyframe_budget_kb(double rate_kbps, double interval_s, const BudgetRule& rule, double fixed_s) {
  const double kb = rate_kbps / 8.0 * (interval_s * rule.headroom - std::max(fixed_s, 0.0));  // kbit/s / 8 = kB/s
  if (!std::isfinite(kb)) return rule.floor_kb;
  return std::clamp(kb, rule.floor_kb, rule.ceiling_kb);
}

void SmoothedDuration::on_sample(double seconds) {
  if (!std::isfinite(seconds)) return;
  seconds = std::max(seconds, 0.0);
  if (samples_ == 0) {
    mean_ = seconds;
    deviation_ = seconds / 2;
  } else {
    deviation_ = 0.75 * deviation_ + 0.25 * std::abs(seconds - mean_);
    mean_ = 0.875 * mean_ + 0.125 * seconds;
  }
  ++samples_;
}

double SmoothedDuration::value() const { return samples_ == 0 ? initial_s_ : mean_ + k_ * deviation_; }

double latency_budget_kb(double estimate_kbps, double overhead_s, const LatencyRule& latency, const BudgetRule& rule,
                         double fixed_s) {
  if (!(latency.target_s > 0)) return rule.ceiling_kb;
  const double post_s =
      std::max(latency.target_s - std::max(overhead_s, 0.0), latency.min_post_share * latency.target_s);
  const double kb = estimate_kbps / 8.0 * (post_s * rule.headroom - std::max(fixed_s, 0.0));
  if (!std::isfinite(kb)) return rule.floor_kb;
  return std::clamp(kb, rule.floor_kb, rule.ceiling_kb);
}

double next_keyframe_budget_kb(double estimate_kbps, double interval_s, double overhead_s, const LatencyRule& latency,
                               const BudgetRule& rule, double fixed_s) {
  return std::min(keyframe_budget_kb(estimate_kbps, interval_s, rule, fixed_s),
                  latency_budget_kb(estimate_kbps, overhead_s, latency, rule, fixed_s));
}

double refinement_budget_kb(double rate_kbps, double window_s, double fixed_s, double ceiling_kb, double headroom) {
  const double kb = rate_kbps / 8.0 * (window_s * headroom - std::max(fixed_s, 0.0));
  if (!std::isfinite(kb) || kb <= 0) return 0;
  return std::min(kb, ceiling_kb);
}

Result<std::optional<double>> CapFile::poll() {
  std::ifstream in(path_, std::ios::binary);
  if (!in) return std::optional<double>();
  std::ostringstream text;
  text << in.rdbuf();
  if (last_text_ && *last_text_ == text.str()) return std::optional<double>();
  last_text_ = text.str();
  std::istringstream parse(text.str());
  double kbps = 0;
  std::string rest;
  if (!(parse >> kbps) || (parse >> rest) || !std::isfinite(kbps) || kbps < 0)
    return make_error(ErrorCode::kInvalidInput, "--link-kbps-file " + path_ +
                                                    ": must hold one number of kbit/s >= 0 (0: no cap); the cap "
                                                    "stays as it was");
  return std::optional<double>(kbps);
}

}  // namespace rgbdcast::stream
