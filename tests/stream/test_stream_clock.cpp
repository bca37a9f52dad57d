// The stream runtime's injected clock (stream/clock.h): a ManualClock wakes a timed wait only when it is moved past
// the deadline, and a notification with the predicate true ends the wait before it; nothing here sleeps.
#include <gtest/gtest.h>

#include <condition_variable>
#include <mutex>
#include <optional>
#include <thread>

#include "stream/clock.h"

namespace rgbdcast::stream {
namespace {

using std::chrono::milliseconds;

TEST(ManualClock, ATimedWaitEndsWhenTheClockPassesItsDeadlineAndNotBefore) {
  ManualClock clock;
  const auto t0 = clock.now();
  std::mutex mu;
  std::condition_variable cv;
  std::optional<bool> result;
  std::thread waiter([&] {
    std::unique_lock lock(mu);
    result = clock.wait_until(lock, cv, t0 + milliseconds(100), [] { return false; });
  });
  EXPECT_EQ(clock.next_deadline(), t0 + milliseconds(100));
  clock.advance(milliseconds(60));
  // Woken (every waiter is, on a move), it found its deadline ahead and sleeps again at the same one.
  EXPECT_EQ(clock.next_deadline(), t0 + milliseconds(100));
  {
    std::lock_guard lock(mu);
    EXPECT_FALSE(result);
  }
  clock.advance(milliseconds(40));
  waiter.join();
  ASSERT_TRUE(result);
  EXPECT_FALSE(*result);  // the deadline, not the predicate
  EXPECT_EQ(clock.now(), t0 + milliseconds(100));
  EXPECT_EQ(clock.timed_waiters(), 0u);
}

TEST(ManualClock, ANotificationWithThePredicateTrueEndsTheWaitWithoutTheClockMoving) {
  ManualClock clock;
  const auto t0 = clock.now();
  std::mutex mu;
  std::condition_variable cv;
  bool ready = false;
  std::optional<bool> result;
  std::thread waiter([&] {
    std::unique_lock lock(mu);
    result = clock.wait_until(lock, cv, t0 + milliseconds(100), [&] { return ready; });
  });
  clock.next_deadline();  // it is asleep
  {
    std::lock_guard lock(mu);
    ready = true;
  }
  cv.notify_all();
  waiter.join();
  ASSERT_TRUE(result);
  EXPECT_TRUE(*result);
  EXPECT_EQ(clock.now(), t0);
}

TEST(ManualClock, AWaitWithoutDeadlineIsNotTimedAndAPassedDeadlineDoesNotWait) {
  ManualClock clock;
  std::mutex mu;
  std::condition_variable cv;
  std::unique_lock lock(mu);
  EXPECT_FALSE(clock.wait_until(lock, cv, clock.now(), [] { return false; }));  // due already: returns at once
  bool ready = false;
  std::thread notifier([&] {
    std::lock_guard held(mu);  // taken once the waiter sleeps
    ready = true;
    cv.notify_all();
  });
  EXPECT_TRUE(clock.wait_until(lock, cv, Clock::kNever, [&] { return ready; }));
  lock.unlock();
  notifier.join();
  EXPECT_EQ(clock.timed_waiters(), 0u);
}

TEST(SystemSteadyClock, WaitsOnTheConditionVariableAndPassedDeadlinesReturnAtOnce) {
  Clock& clock = system_steady_clock();
  std::mutex mu;
  std::condition_variable cv;
  std::unique_lock lock(mu);
  const auto before = clock.now();
  EXPECT_FALSE(clock.wait_until(lock, cv, before - milliseconds(1), [] { return false; }));
  EXPECT_GE(clock.now(), before);
  bool ready = false;
  std::thread notifier([&] {
    std::lock_guard held(mu);
    ready = true;
    cv.notify_all();
  });
  EXPECT_TRUE(clock.wait_until(lock, cv, Clock::kNever, [&] { return ready; }));
  lock.unlock();
  notifier.join();
}

}  // namespace
}  // namespace rgbdcast::stream
