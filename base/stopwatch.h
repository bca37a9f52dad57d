#pragma once
// Elapsed time on the steady clock in milliseconds: the one definition the stages' reports, the renderers and the
// services time their work with. And the one reading of the wall clock as Unix seconds, for the times written into
// records (a keyframe's capture, a scene's creation), which durations are not measured on.
#include <chrono>

namespace rgbdcast {

using SteadyClock = std::chrono::steady_clock;

// Milliseconds from t0 to t1 (negative when t1 is earlier).
inline double ms_between(SteadyClock::time_point t0, SteadyClock::time_point t1) {
  return std::chrono::duration<double, std::milli>(t1 - t0).count();
}

// Milliseconds from t0 to now.
inline double ms_since(SteadyClock::time_point t0) { return ms_between(t0, SteadyClock::now()); }

// Seconds since the Unix epoch on the system clock (it may step: not for durations).
inline double unix_seconds_now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

}  // namespace rgbdcast
