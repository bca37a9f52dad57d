#include "base/stopwatch.h"

#include <gtest/gtest.h>

namespace rgbdcast {
namespace {

TEST(Stopwatch, MillisecondsBetweenTwoTimePoints) {
  const SteadyClock::time_point t0{};
  struct Case {
    std::chrono::nanoseconds elapsed;
    double ms;
  };
  for (const Case& c : {Case{std::chrono::nanoseconds(0), 0.0}, Case{std::chrono::microseconds(1500), 1.5},
                        Case{std::chrono::seconds(2), 2000.0}, Case{std::chrono::nanoseconds(250), 0.00025},
                        Case{-std::chrono::milliseconds(3), -3.0}})
    EXPECT_DOUBLE_EQ(ms_between(t0, t0 + c.elapsed), c.ms) << c.elapsed.count() << " ns";
}

TEST(Stopwatch, SinceAPointInThePastIsNotNegative) {
  const SteadyClock::time_point t0 = SteadyClock::now() - std::chrono::milliseconds(5);
  EXPECT_GE(ms_since(t0), 5.0);  // the steady clock never goes back
}

}  // namespace
}  // namespace rgbdcast
