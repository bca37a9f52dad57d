#pragma once
// The stream runtime's monotonic clock, injected so that what it paces and times out (the camera's frame times, the
// sender's pacing and backoff, the producer's hold-back) can run on a manual clock in tests, without sleeping.
// Time points are on the steady clock's type with steady semantics (never going back); a ManualClock's are on its
// own scale, so only differences and comparisons between its own time points mean anything. Wall-clock facts
// written into records (Unix seconds) are not on this clock.
//
// A timed wait goes through the clock: wait_until() waits on a condition variable until it is notified or the
// clock reaches the deadline, whichever comes first (the system clock: std::condition_variable::wait_until; a
// ManualClock: until advance() passes the deadline).
#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <vector>

namespace rgbdcast::stream {

class Clock {
 public:
  using time_point = std::chrono::steady_clock::time_point;
  using duration = std::chrono::steady_clock::duration;
  // A deadline that never comes: wait_until then waits for a notification only.
  static constexpr time_point kNever = time_point::max();

  virtual ~Clock() = default;
  virtual time_point now() const = 0;
  // One wait: returns when cv is notified (or wakes spuriously) or the clock reached `deadline`. `lock` holds cv's
  // mutex on entry and on return. Callers re-check their state in a loop, as with a condition variable.
  virtual void wait_until(std::unique_lock<std::mutex>& lock, std::condition_variable& cv, time_point deadline) = 0;
  // Waits until pred() holds (true) or the clock reached `deadline` with pred() still false (false). pred is read
  // under `lock`; every writer of what it reads must notify cv after changing it under that mutex.
  bool wait_until(std::unique_lock<std::mutex>& lock, std::condition_variable& cv, time_point deadline,
                  const std::function<bool()>& pred);

  double seconds(time_point t) const { return std::chrono::duration<double>(t.time_since_epoch()).count(); }
  double now_s() const { return seconds(now()); }
  static duration from_seconds(double s) {
    return std::chrono::duration_cast<duration>(std::chrono::duration<double>(s));
  }
};

// The process's steady clock (one shared instance).
Clock& system_steady_clock();

// A clock that moves only when advance() or set() is called. For tests: a thread waiting on it (wait_until) wakes
// when the clock passes its deadline. Thread-safe; advance() must not run while an object whose thread waits on it
// is being destroyed (it notifies the waiters' condition variables after the time changed).
class ManualClock : public Clock {
 public:
  explicit ManualClock(time_point start = time_point{} + std::chrono::hours(1)) : now_(start) {}
  time_point now() const override;
  void wait_until(std::unique_lock<std::mutex>& lock, std::condition_variable& cv, time_point deadline) override;
  using Clock::wait_until;

  void advance(duration d);
  void set(time_point t);  // not before now()
  // Blocks until at least `count` threads are asleep on this clock with a deadline still ahead (not kNever, after
  // now()), and returns the earliest of those deadlines: what the clock must reach for the next timed wake. A
  // waiter whose deadline the clock passed is not counted (it is waking). A test steps a thread to its next timed
  // wait with it instead of sleeping.
  time_point next_deadline(size_t count = 1) const;
  size_t timed_waiters() const;  // asleep with a deadline still ahead

 private:
  struct Waiter {
    std::mutex* mu;
    std::condition_variable* cv;
    time_point deadline;
  };
  void wake_all();
  bool asleep_locked(const Waiter& w) const { return w.deadline != kNever && w.deadline > now_; }
  size_t timed_waiters_locked() const;

  mutable std::mutex mu_;
  mutable std::condition_variable waiters_cv_;  // a waiter came or went
  time_point now_;
  std::vector<const Waiter*> waiters_;
};

}  // namespace rgbdcast::stream
