#include "stream/sender.h"

#include <algorithm>
#include <nlohmann/json.hpp>

#include "base/stopwatch.h"

namespace rgbdcast::stream {

Sender::Sender(Outbox& outbox, Uplink& uplink, const SenderParams& params)
    : Sender(outbox, std::vector<Uplink*>{&uplink}, params) {}

Sender::Sender(Outbox& outbox, std::vector<Uplink*> uplinks, const SenderParams& params)
    : outbox_(outbox),
      uplinks_(std::move(uplinks)),
      params_(params),
      clock_(params.clock ? *params.clock : system_steady_clock()),
      unix_s_(params.unix_s ? params.unix_s : unix_seconds_now),
      estimator_(params.link),
      backoff_(params.backoff),
      rng_(params.seed ? params.seed : std::random_device{}()) {
  stats_.lanes = uplinks_.size();
}

Sender::~Sender() { stop(); }

void Sender::start() {
  std::lock_guard lock(mu_);
  if (!threads_.empty() || stopping_) return;
  for (Uplink* u : uplinks_) threads_.emplace_back([this, u] { run(*u); });
}

void Sender::stop() {
  {
    std::lock_guard lock(mu_);
    stopping_ = true;
  }
  cv_.notify_all();
  for (std::thread& t : threads_)
    if (t.joinable()) t.join();
}

// The outbox is changed outside mu_: taking it here orders the change before a lane's next look (a lane checks the
// outbox and starts waiting under mu_, so the notification cannot fall between the two).
void Sender::notify() {
  { std::lock_guard lock(mu_); }
  cv_.notify_all();
}

void Sender::set_on_change(std::function<void()> on_change) {
  std::lock_guard lock(mu_);
  on_change_ = std::move(on_change);
}

void Sender::changed() {
  std::function<void()> on_change;
  {
    std::lock_guard lock(mu_);
    on_change = on_change_;
  }
  cv_.notify_all();
  if (on_change) on_change();
}

std::optional<OutboxEntry> Sender::wait_entry(int seq,
                                              const std::function<bool(const std::optional<OutboxEntry>&)>& done,
                                              std::chrono::milliseconds timeout, std::optional<bool> link_down_was) {
  std::unique_lock lock(mu_);
  std::optional<OutboxEntry> e;
  clock_.wait_until(lock, cv_, clock_.now() + timeout, [&] {
    e = outbox_.entry(seq);
    return stopping_ || (link_down_was && *link_down_was != stats_.link_down) || done(e);
  });
  return e;
}

bool Sender::wait_delivered(std::chrono::milliseconds timeout) {
  std::unique_lock lock(mu_);
  auto delivered = [&] {
    for (const OutboxEntry& e : outbox_.entries())
      if (e.pending()) return false;
    return true;
  };
  clock_.wait_until(lock, cv_, clock_.now() + timeout, [&] { return stopping_ || delivered(); });
  return delivered();
}

bool Sender::claim(int seq) {
  {
    std::lock_guard lock(mu_);
    auto e = outbox_.entry(seq);
    if (!e || e->attempted || in_flight_.count({seq, e->rev})) return false;
    claimed_.insert(seq);
  }
  cv_.notify_all();  // a refinement's chunk waiting for this first revision to start goes on (the gate in run)
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

double Sender::line_kbps() const {
  std::lock_guard lock(mu_);
  return estimator_.line_kbps();
}

double Sender::post_fixed_s() const {
  std::lock_guard lock(mu_);
  return estimator_.post_fixed_s();
}

double Sender::owed_s(bool include_refinements) const {
  std::lock_guard lock(mu_);
  const auto [line_s, bytes_s] = owed_parts_locked(include_refinements);
  return line_s + bytes_s;
}

Clock::time_point Sender::owed_falls_to(double s, bool include_refinements) const {
  std::lock_guard lock(mu_);
  const auto [line_s, bytes_s] = owed_parts_locked(include_refinements);
  if (line_s + bytes_s <= s) return clock_.now();
  if (bytes_s > s) return Clock::kNever;
  // Not now or before: owed_s said more than s at this time (a rounding of the two parts must not make a caller's
  // wait return at once, again and again, on a clock that does not move by itself).
  return std::max(line_free_ - Clock::from_seconds(s - bytes_s), clock_.now() + Clock::duration(1));
}

std::pair<double, double> Sender::owed_parts_locked(bool include_refinements) const {
  const double estimate_bps = std::max(estimator_.estimate_kbps(), 1.0) * 1000.0 / 8.0;
  const bool paced = estimator_.cap_kbps() > 0;
  double bytes = 0;
  for (const OutboxEntry& e : outbox_.entries())
    if (e.pending() && !(paced && (e.attempted || in_flight_.count({e.seq, e.rev}))) &&
        (include_refinements || e.rev == 0 || in_flight_.count({e.seq, e.rev})))
      bytes += static_cast<double>(e.bytes);
  if (include_refinements) bytes += static_cast<double>(refinement_left_bytes_);  // a refinement being written
  double line_s = 0;
  if (paced) line_s = std::max(0.0, std::chrono::duration<double>(line_free_ - clock_.now()).count());
  return {line_s, bytes / estimate_bps};
}

bool Sender::idle() const {
  std::lock_guard lock(mu_);
  if (!in_flight_.empty()) return false;
  for (const OutboxEntry& e : outbox_.entries())
    if (e.pending()) return false;
  return true;
}

bool Sender::refinements_yield() const {
  std::lock_guard lock(mu_);
  return estimator_.cap_kbps() > 0 && uplinks_.size() >= 2;
}

// Not on_change: the producer sets the cap itself (under its own lock).
void Sender::set_cap_kbps(double cap_kbps) {
  {
    std::lock_guard lock(mu_);
    estimator_.set_cap_kbps(cap_kbps);
  }
  cv_.notify_all();  // a lane pacing at the old cap recomputes when it may start
}

double Sender::cap_kbps() const {
  std::lock_guard lock(mu_);
  return estimator_.cap_kbps();
}

SenderStats Sender::stats() const {
  std::lock_guard lock(mu_);
  SenderStats s = stats_;
  s.acked = s.rejected = s.pending = s.pending_bytes = 0;
  for (const OutboxEntry& e : outbox_.entries()) {
    if (e.acked)
      ++s.acked;
    else if (!e.rejected.empty())
      ++s.rejected;
    else {
      ++s.pending;
      s.pending_bytes += e.bytes;
    }
  }
  s.estimate_kbps = estimator_.estimate_kbps();
  s.line_kbps = estimator_.line_kbps();
  s.post_fixed_s = estimator_.post_fixed_s();
  s.cap_kbps = estimator_.cap_kbps();
  const auto now = clock_.now();  // the intervals still open
  if (!in_flight_.empty()) s.busy_s += std::chrono::duration<double>(now - busy_since_).count();
  if (in_flight_.size() >= 2) s.overlap_s += std::chrono::duration<double>(now - overlap_since_).count();
  return s;
}

Clock::duration Sender::line_time(size_t bytes) const {
  return std::chrono::microseconds(
      static_cast<long long>(static_cast<double>(bytes) * 8.0 / (estimator_.cap_kbps() * 1000.0) * 1e6));
}

std::vector<PostRecord> Sender::post_log() const {
  std::lock_guard lock(mu_);
  return post_log_;
}

void Sender::flight_begin_locked(int seq, int rev) {
  const auto now = clock_.now();
  in_flight_.insert({seq, rev});
  if (in_flight_.size() == 1) busy_since_ = now;
  if (in_flight_.size() == 2) overlap_since_ = now;
}

void Sender::flight_end_locked(int seq, int rev) {
  if (!in_flight_.erase({seq, rev})) return;
  const auto now = clock_.now();
  if (in_flight_.empty()) stats_.busy_s += std::chrono::duration<double>(now - busy_since_).count();
  if (in_flight_.size() == 1) stats_.overlap_s += std::chrono::duration<double>(now - overlap_since_).count();
}

// The newest pending entry (first revisions before refinements, then by capture time, then seq) that the producer
// has not claimed and whose revision no lane is posting (an older revision of it may be in flight: see
// Outbox::revise_in_flight); none when there is none.
std::optional<OutboxEntry> Sender::pick_locked() const {
  const OutboxEntry* best = nullptr;
  const auto entries = outbox_.entries();
  // One refinement's body is written at a time (paced, it yields to first revisions; two paused ones could hold
  // both lanes while a keyframe waits for one).
  const bool refinement_writing = refinement_writing_;
  size_t first_in_flight = 0;
  for (const auto& [seq, rev] : in_flight_)
    if (rev == 0) ++first_in_flight;
  const bool first_ok = params_.max_first_in_flight == 0 || first_in_flight < params_.max_first_in_flight;
  const bool refinement_ok = !refinement_writing && (uplinks_.size() < 2 || in_flight_.size() + 1 < uplinks_.size());
  auto before = [](const OutboxEntry& a, const OutboxEntry& b) {  // a goes before b
    if ((a.rev == 0) != (b.rev == 0)) return a.rev == 0;
    if (a.captured != b.captured) return a.captured > b.captured;
    return a.seq > b.seq;
  };
  for (const OutboxEntry& e : entries)
    if (e.pending() && !claimed_.count(e.seq) && !in_flight_.count({e.seq, e.rev}) &&
        (e.rev > 0 ? refinement_ok : first_ok) && (!best || before(e, *best)))
      best = &e;
  if (!best) return std::nullopt;
  return *best;
}

bool Sender::first_revision_waiting_locked() const {
  if (clock_.now() < retry_not_before_) return false;  // backing off: nothing starts meanwhile
  // With one lane the refinement holds it: the keyframe waits for the whole body (as every POST waits for the one
  // before). With more, the other lanes hold first revisions or a refinement whose body is written (pick_locked):
  // each ends with its answer, so a keyframe waiting for one of them starts within a round trip.
  if (uplinks_.size() < 2) return false;
  for (const OutboxEntry& e : outbox_.entries())
    if (e.pending() && e.rev == 0 && !claimed_.count(e.seq) && !in_flight_.count({e.seq, 0})) return true;
  return false;
}

std::optional<OutboxEntry> Sender::next_post(bool& paced_chunks) {
  std::unique_lock lock(mu_);
  std::optional<OutboxEntry> entry;
  for (;;) {
    if (stopping_) return std::nullopt;
    const auto now = clock_.now();
    const auto not_before = std::max(retry_not_before_, estimator_.cap_kbps() > 0 ? line_free_ : now);
    if (now < not_before) {  // pacing or backoff: a deadline on the clock (or a change: a cap set or lifted)
      clock_.wait_until(lock, cv_, not_before);
      continue;
    }
    entry = pick_locked();
    if (entry) break;
    // Nothing to pick until what pick_locked reads changes, and each writer notifies cv_ under or after mu_: a new
    // entry or revision (notify), a claim released, an answer or a lane's end (finish), a refinement's body done
    // (writing_done_locked), the stop.
    cv_.wait(lock);
  }
  flight_begin_locked(entry->seq, entry->rev);
  // Pacing: a first revision's body takes bytes / cap on the virtual line, after the bodies already on it; a
  // refinement's is put on it chunk by chunk as it is written (run's gate), so that a first revision that comes
  // meanwhile goes ahead of the rest of it.
  paced_chunks = false;
  if (estimator_.cap_kbps() > 0) {
    if (entry->rev > 0) {
      paced_chunks = true;
      refinement_writing_ = true;
      refinement_writer_ = entry->seq;
      refinement_left_bytes_ = entry->bytes;
    } else {
      line_free_ = std::max(line_free_, clock_.now()) + line_time(entry->bytes);
    }
  }
  return entry;
}

void Sender::run(Uplink& uplink) {
  for (;;) {
    bool paced_chunks = false;  // a refinement's body under a cap: written through the gate
    // The revision this lane posts (as picked: a newer one may come meanwhile).
    const std::optional<OutboxEntry> entry = next_post(paced_chunks);
    if (!entry) return;
    const int seq = entry->seq;
    changed();  // a refinement paused for this first revision recomputes its next chunk's start; owed_s changed
    // The gate of a paced refinement: each chunk waits until the virtual line is free and no first revision is
    // waiting to start (a new keyframe goes ahead of the rest of the body), then takes bytes / cap on it. A body
    // that had to wait for another one is `preempted`: its POST's time is not a sample of the link.
    bool preempted = false;
    // Only the refinement being written clears the state: one whose body is done and whose answer comes while the
    // next refinement is being written must not (it would let a third start beside it).
    // (mu_ held) The body is done, or given up on: a lane waiting for a refinement to write may take the next one now.
    auto writing_done_locked = [&] {
      refinement_writing_ = false;
      refinement_writer_ = -1;
      refinement_left_bytes_ = 0;
      cv_.notify_all();
    };
    auto end_writing = [&] {
      if (!paced_chunks) return;
      std::lock_guard lock(mu_);
      if (refinement_writer_ == seq) writing_done_locked();
    };
    const ChunkGate gate = [&](size_t offset, size_t bytes) {
      std::unique_lock lock(mu_);
      for (;;) {
        if (stopping_) return false;
        const double cap = estimator_.cap_kbps();
        if (cap <= 0) break;  // the cap was lifted: written at once
        const auto now = clock_.now();
        const bool keyframe_waiting = first_revision_waiting_locked();
        if (!keyframe_waiting && line_free_ <= now) break;
        if (keyframe_waiting || (offset > 0 && line_free_ > own_line_end_)) preempted = true;
        // A waiting first revision stops waiting when it starts (run notifies after next_post), is claimed, or an
        // answer or backoff comes (finish): each notifies cv_. Otherwise the line frees at line_free_.
        clock_.wait_until(lock, cv_, keyframe_waiting ? Clock::kNever : line_free_);
      }
      if (estimator_.cap_kbps() > 0) line_free_ = std::max(line_free_, clock_.now()) + line_time(bytes);
      own_line_end_ = line_free_;
      refinement_left_bytes_ = offset + bytes >= refinement_bytes_total_ ? 0 : refinement_bytes_total_ - offset - bytes;
      if (refinement_left_bytes_ == 0) writing_done_locked();  // its last chunk is on the line
      lock.unlock();
      changed();  // owed_s changed: the chunk left the refinement's bytes for the line
      return true;
    };
    auto finish = [&](const std::string& fatal) {
      end_writing();
      {
        std::lock_guard lock(mu_);
        flight_end_locked(seq, entry->rev);
        if (!fatal.empty()) {
          stats_.fatal = fatal;
          stopping_ = true;
        }
      }
      changed();  // another lane may wait for this entry (a retry) or for the stop; the producer for the answer
    };
    const double post_started = unix_s_();
    note_queue_wait(*entry, post_started);
    // The GLB is read before the entry is marked attempted, so that a revision added beside this POST once it is
    // marked (Outbox::revise_in_flight, which removes the older GLB) cannot take its body's place.
    auto glb = outbox_.read_glb(seq, entry->rev);
    if (!glb) {
      auto now = outbox_.entry(seq);
      if (now && now->rev > entry->rev) {  // a newer revision replaced it since it was picked: that one goes
        finish("");
        continue;
      }
      finish(glb.error().message);
      return;
    }
    if (Status st = outbox_.mark_attempted(seq, post_started, entry->rev); !st) {
      finish(st.error().message);
      return;
    }
    changed();  // the producer may wait for this entry to be attempted (wait_entry; changed() takes mu_ first)
    const double io_timeout_s = answer_timeout_s(glb->size(), estimate_kbps());
    if (paced_chunks) {
      std::lock_guard lock(mu_);
      refinement_bytes_total_ = glb->size();
      own_line_end_ = line_free_;
    }
    PostResult r = uplink.post_keyframe(params_.mission, *entry, *glb, io_timeout_s, paced_chunks ? gate : ChunkGate{});
    end_writing();
    if (r.outcome == PostOutcome::kConflict) resolve_conflict(uplink, *entry, glb->size(), r);
    // The link's sample goes in before the outbox says acknowledged: a thread that sees the answer must see what it
    // measured (keyframe_stream.cpp checks a refinement made ahead against the measured link then; in between it
    // read the initial guess and kept a revision the measured link could not carry).
    if (r.outcome == PostOutcome::kStored && !preempted) {
      std::lock_guard lock(mu_);
      estimator_.on_ack(glb->size(), r.seconds);
    }
    Status written = ok_status();
    if (r.outcome == PostOutcome::kStored) written = outbox_.mark_acked(seq, r.body, entry->rev);
    if (r.outcome == PostOutcome::kRejected) written = outbox_.mark_rejected(seq, r.error, entry->rev);
    {
      std::lock_guard lock(mu_);
      record_post_locked(*entry, glb->size(), post_started, r);
    }
    if (r.outcome == PostOutcome::kFatal) {
      finish("the server refused the sender: " + r.error);
      return;
    }
    finish(written ? std::string() : written.error().message);
    if (!written) return;
  }
}

// A first revision's wait only: a refinement's `reduced` is its keyframe's, seconds or minutes ago, and would make
// the latency rule starve the keyframes that follow it.
void Sender::note_queue_wait(const OutboxEntry& entry, double post_started) {
  if (entry.attempted || entry.rev != 0 || !(entry.reduced > 0)) return;
  const double wait = std::max(0.0, post_started - entry.reduced);
  std::lock_guard lock(mu_);
  queue_wait_s_ = queue_wait_s_ ? 0.3 * wait + 0.7 * *queue_wait_s_ : wait;
}

// Ours from an earlier run whose answer was lost and whose bytes changed since? The mission is read back: stored
// (stored_keyframe) or rejected; a failed read is retried.
void Sender::resolve_conflict(Uplink& uplink, const OutboxEntry& entry, size_t bytes, PostResult& r) {
  auto mission = uplink.get_mission(params_.mission);
  if (!mission) {
    r.outcome = PostOutcome::kRetry;
    r.error += "; reading the mission back: " + mission.error().message;
    return;
  }
  auto stored = stored_keyframe(*mission, entry.seq, entry.rev, bytes);
  if (stored) r.body = std::move(*stored);
  r.outcome = stored ? PostOutcome::kStored : PostOutcome::kRejected;
}

void Sender::record_post_locked(const OutboxEntry& entry, size_t bytes, double post_started, const PostResult& r) {
  ++stats_.posts;
  post_log_.push_back({entry.seq, entry.rev, bytes, post_started, unix_s_(), r.outcome == PostOutcome::kStored});
  switch (r.outcome) {
    case PostOutcome::kStored:  // (the link's sample went in before the outbox was told)
      backoff_.reset();
      stats_.acked_bytes += bytes;
      if (entry.rev > 0) {
        ++stats_.refinements_acked;
        stats_.refinement_bytes += bytes;
      }
      stats_.link_down = false;
      break;
    case PostOutcome::kRetry: {
      estimator_.on_failure();
      ++stats_.failures;
      stats_.link_down = true;
      stats_.last_error = r.error;
      const double delay = backoff_.next_delay_s(rng_, r.retry_after_s);
      retry_not_before_ =
          std::max(retry_not_before_, clock_.now() + std::chrono::microseconds(static_cast<long long>(delay * 1e6)));
      break;
    }
    case PostOutcome::kRejected:
      stats_.last_error = "keyframe " + std::to_string(entry.seq) + " rejected: " + r.error;
      break;
    case PostOutcome::kConflict:  // resolved before (resolve_conflict)
    case PostOutcome::kFatal:
      break;
  }
}

double answer_timeout_s(size_t bytes, double estimate_kbps) {
  const double transfer_s = static_cast<double>(bytes) * 8.0 / 1000.0 / std::max(estimate_kbps, 64.0);
  return std::clamp(3.0 + 4.0 * transfer_s, 3.0, 60.0);
}

std::optional<std::string> stored_keyframe(const std::string& mission_json, int seq, int rev, size_t bytes) {
  auto j = nlohmann::json::parse(mission_json, nullptr, false);
  std::optional<std::string> out;
  if (!j.is_object() || !j.contains("keyframes") || !j["keyframes"].is_array()) return out;
  for (const auto& k : j["keyframes"]) {
    if (k.value("seq", -1) != seq) continue;
    const int stored_rev = k.value("rev", 0);
    if ((stored_rev == rev && k.value("bytes", size_t{0}) == bytes) || stored_rev > rev) out = k.dump();
  }
  return out;
}

}  // namespace rgbdcast::stream
