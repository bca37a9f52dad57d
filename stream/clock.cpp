#include "stream/clock.h"

#include <algorithm>

namespace rgbdcast::stream {

namespace {

class SystemClock : public Clock {
 public:
  time_point now() const override { return std::chrono::steady_clock::now(); }
  void wait_until(std::unique_lock<std::mutex>& lock, std::condition_variable& cv, time_point deadline) override {
    if (deadline == kNever)
      cv.wait(lock);
    else
      cv.wait_until(lock, deadline);
  }
};

}  // namespace

bool Clock::wait_until(std::unique_lock<std::mutex>& lock, std::condition_variable& cv, time_point deadline,
                       const std::function<bool()>& pred) {
  while (!pred()) {
    if (now() >= deadline) return pred();
    wait_until(lock, cv, deadline);
  }
  return true;
}

Clock& system_steady_clock() {
  static SystemClock clock;
  return clock;
}

Clock::time_point ManualClock::now() const {
  std::lock_guard lock(mu_);
  return now_;
}

// The waiter registers while it holds its own mutex and keeps it until cv.wait releases it; advance() takes that
// mutex before notifying, so a wake cannot fall between the waiter's check of the time and its wait.
void ManualClock::wait_until(std::unique_lock<std::mutex>& lock, std::condition_variable& cv, time_point deadline) {
  const Waiter self{lock.mutex(), &cv, deadline};
  {
    std::lock_guard g(mu_);
    if (now_ >= deadline) return;
    waiters_.push_back(&self);
  }
  waiters_cv_.notify_all();
  cv.wait(lock);
  {
    std::lock_guard g(mu_);
    waiters_.erase(std::find(waiters_.begin(), waiters_.end(), &self));
  }
  waiters_cv_.notify_all();
}

void ManualClock::advance(duration d) {
  {
    std::lock_guard lock(mu_);
    now_ += d;
  }
  waiters_cv_.notify_all();
  wake_all();
}

void ManualClock::set(time_point t) {
  {
    std::lock_guard lock(mu_);
    now_ = std::max(now_, t);
  }
  waiters_cv_.notify_all();
  wake_all();
}

// Every waiter, not only those whose deadline passed: a waiter re-checks its own deadline (a spurious wake for the
// others). The waiters' mutexes are taken without mu_ held: a waiter holds its own while it reads now().
void ManualClock::wake_all() {
  std::vector<Waiter> to_wake;
  {
    std::lock_guard lock(mu_);
    for (const Waiter* w : waiters_) to_wake.push_back(*w);
  }
  for (const Waiter& w : to_wake) {
    { std::lock_guard held(*w.mu); }
    w.cv->notify_all();
  }
}

Clock::time_point ManualClock::next_deadline(size_t count) const {
  std::unique_lock lock(mu_);
  time_point earliest = kNever;
  waiters_cv_.wait(lock, [&] {
    earliest = kNever;
    for (const Waiter* w : waiters_)
      if (asleep_locked(*w)) earliest = std::min(earliest, w->deadline);
    return timed_waiters_locked() >= count;
  });
  return earliest;
}

size_t ManualClock::timed_waiters() const {
  std::lock_guard lock(mu_);
  return timed_waiters_locked();
}

size_t ManualClock::timed_waiters_locked() const {
  return static_cast<size_t>(
      std::count_if(waiters_.begin(), waiters_.end(), [&](const Waiter* w) { return asleep_locked(*w); }));
}

}  // namespace rgbdcast::stream
