#include "stream/backoff.h"

#include <algorithm>
#include <cmath>

namespace rgbdcast::stream {

Status BackoffParams::validate() const {
  if (!(initial_s > 0 && factor >= 1 && max_s >= initial_s && jitter >= 0 && jitter <= 1 && retry_after_max_s >= 0))
    return make_error(ErrorCode::kInvalidArgument,
                      "backoff: need initial > 0, factor >= 1, max >= initial, jitter in [0, 1]");
  return ok_status();
}

double Backoff::next_delay_s(std::mt19937& rng, double retry_after_s) {
  const double exponent = std::min(failures_, 60);  // beyond that the cap holds anyway
  const double d = std::min(params_.max_s, params_.initial_s * std::pow(params_.factor, exponent));
  ++failures_;
  std::uniform_real_distribution<double> u(1.0 - params_.jitter, 1.0);
  double delay = d * u(rng);
  if (retry_after_s > 0) delay = std::max(delay, std::min(retry_after_s, params_.retry_after_max_s));
  return delay;
}

}  // namespace rgbdcast::stream
