#include "stream/sender.h"

#include <algorithm>
#include <nlohmann/json.hpp>

namespace rgbdcast::stream {

using clock = std::chrono::steady_clock;

namespace {
double unix_now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}
}  // namespace

Sender::Sender(Outbox& outbox, Uplink& uplink, const SenderParams& params)
    : outbox_(outbox),
      uplink_(uplink),
      params_(params),
      estimator_(params.link),
      backoff_(params.backoff),
      rng_(params.seed ? params.seed : std::random_device{}()) {}

Sender::~Sender() { stop(); }

void Sender::start() {
  std::lock_guard lock(mu_);
  if (!thread_.joinable()) thread_ = std::thread([this] { run(); });
}

void Sender::stop() {
  {
    std::lock_guard lock(mu_);
    stopping_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void Sender::notify() { cv_.notify_all(); }

bool Sender::claim(int seq) {
  std::lock_guard lock(mu_);
  auto e = outbox_.entry(seq);
  if (!e || e->attempted || in_flight_ == seq) return false;
  claimed_.insert(seq);
  return true;
}

void Sender::release(int seq) {
  {
    std::lock_guard lock(mu_);
    claimed_.erase(seq);
  }
  cv_.notify_all();
}

double Sender::estimate_kbps() const {
  std::lock_guard lock(mu_);
  return estimator_.estimate_kbps();
}

double Sender::queue_wait_s() const {
  std::lock_guard lock(mu_);
  return queue_wait_s_.value_or(0.0);
}

size_t Sender::acknowledged_posts() const {
  std::lock_guard lock(mu_);
  return estimator_.samples();
}

void Sender::set_cap_kbps(double cap_kbps) {
  std::lock_guard lock(mu_);
  estimator_.set_cap_kbps(cap_kbps);
}

SenderStats Sender::stats() const {
  std::lock_guard lock(mu_);
  SenderStats s = stats_;
  s.acked = s.rejected = s.pending = s.pending_bytes = 0;
  for (const OutboxEntry& e : outbox_.entries()) {
    if (e.acked) ++s.acked;
    else if (!e.rejected.empty()) ++s.rejected;
    else {
      ++s.pending;
      s.pending_bytes += e.bytes;
    }
  }
  s.estimate_kbps = estimator_.estimate_kbps();
  s.cap_kbps = estimator_.cap_kbps();
  return s;
}

// The newest pending entry that the producer has not claimed; -1 when none.
int Sender::pick_locked(clock::time_point) const {
  const auto entries = outbox_.entries();
  for (auto it = entries.rbegin(); it != entries.rend(); ++it)
    if (it->pending() && !claimed_.count(it->seq)) return it->seq;
  return -1;
}

void Sender::run() {
  for (;;) {
    int seq = -1;
    {
      std::unique_lock lock(mu_);
      for (;;) {
        if (stopping_) return;
        const auto now = clock::now();
        if (now < not_before_) {
          cv_.wait_until(lock, not_before_);
          continue;
        }
        seq = pick_locked(now);
        if (seq >= 0) break;
        cv_.wait_for(lock, std::chrono::milliseconds(200));
      }
      in_flight_ = seq;
    }
    auto finish = [&](const std::string& fatal) {
      std::lock_guard lock(mu_);
      in_flight_ = -1;
      if (!fatal.empty()) {
        stats_.fatal = fatal;
        stopping_ = true;
      }
    };
    std::optional<OutboxEntry> entry = outbox_.entry(seq);
    if (!entry) {
      finish("outbox: keyframe " + std::to_string(seq) + " vanished");
      return;
    }
    const double post_started = unix_now();
    if (!entry->attempted && entry->reduced > 0) {
      const double wait = std::max(0.0, post_started - entry->reduced);
      std::lock_guard lock(mu_);
      queue_wait_s_ = queue_wait_s_ ? 0.3 * wait + 0.7 * *queue_wait_s_ : wait;
    }
    if (Status st = outbox_.mark_attempted(seq, post_started); !st) {
      finish(st.error().message);
      return;
    }
    auto glb = outbox_.read_glb(seq);
    if (!glb) {
      finish(glb.error().message);
      return;
    }
    // The wait for an answer: 3 s plus 4 x the transfer time at the estimate, but not at an estimate that failures
    // pushed below 64 kbit/s: after an outage a blackholed request must be given up on within seconds.
    const double estimate = std::max(estimate_kbps(), 64.0);
    const double transfer_s = static_cast<double>(glb->size()) * 8.0 / 1000.0 / estimate;
    const double io_timeout_s = std::clamp(3.0 + 4.0 * transfer_s, 3.0, 60.0);
    const auto started = clock::now();
    PostResult r = uplink_.post_keyframe(params_.mission, *entry, *glb, io_timeout_s);
    if (r.outcome == PostOutcome::kConflict) {
      // Ours from an earlier run whose answer was lost and whose bytes changed since? Read the mission back.
      auto mission = uplink_.get_mission(params_.mission);
      if (!mission) {
        r.outcome = PostOutcome::kRetry;
        r.error += "; reading the mission back: " + mission.error().message;
      } else {
        auto j = nlohmann::json::parse(*mission, nullptr, false);
        bool same = false;
        if (j.is_object() && j.contains("keyframes") && j["keyframes"].is_array())
          for (const auto& k : j["keyframes"])
            if (k.value("seq", -1) == seq && k.value("bytes", size_t{0}) == glb->size()) {
              same = true;
              r.body = k.dump();
            }
        r.outcome = same ? PostOutcome::kStored : PostOutcome::kRejected;
      }
    }
    Status written = ok_status();
    if (r.outcome == PostOutcome::kStored) written = outbox_.mark_acked(seq, r.body);
    if (r.outcome == PostOutcome::kRejected) written = outbox_.mark_rejected(seq, r.error);
    {
      std::lock_guard lock(mu_);
      ++stats_.posts;
      stats_.busy_s += r.seconds;
      switch (r.outcome) {
        case PostOutcome::kStored:
          estimator_.on_ack(glb->size(), r.seconds);
          backoff_.reset();
          stats_.acked_bytes += glb->size();
          stats_.link_down = false;
          if (estimator_.cap_kbps() > 0)
            not_before_ = started + std::chrono::microseconds(static_cast<long long>(
                                        glb->size() * 8.0 / (estimator_.cap_kbps() * 1000.0) * 1e6));
          break;
        case PostOutcome::kRetry: {
          estimator_.on_failure();
          ++stats_.failures;
          stats_.link_down = true;
          stats_.last_error = r.error;
          const double delay = backoff_.next_delay_s(rng_, r.retry_after_s);
          not_before_ = clock::now() + std::chrono::microseconds(static_cast<long long>(delay * 1e6));
          break;
        }
        case PostOutcome::kRejected:
          stats_.last_error = "keyframe " + std::to_string(seq) + " rejected: " + r.error;
          break;
        case PostOutcome::kConflict:  // resolved above
        case PostOutcome::kFatal:
          break;
      }
    }
    if (r.outcome == PostOutcome::kFatal) {
      finish("the server refused the sender: " + r.error);
      return;
    }
    finish(written ? std::string() : written.error().message);
    if (!written) return;
  }
}

}  // namespace rgbdcast::stream
