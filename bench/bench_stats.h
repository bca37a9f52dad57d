#pragma once
// What every benchmark program here needs: medians and quantiles of repeated measurements, and a wall-clock timer.
#include <algorithm>
#include <chrono>
#include <ctime>
#include <vector>

#include "base/stopwatch.h"

namespace rgbdcast::bench {

// The q-quantile (0..1) of v, by the nearest rank; 0 for an empty v. median(v) is quantile(v, 0.5).
inline double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * v.size()))];
}
inline double median(std::vector<double> v) { return quantile(std::move(v), 0.5); }

// Milliseconds that f() took (steady clock).
template <typename F>
double time_ms(F&& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return ms_since(t0);
}

// CPU milliseconds that f() took: on the calling thread (CLOCK_THREAD_CPUTIME_ID), or summed over the process's
// threads (CLOCK_PROCESS_CPUTIME_ID). Unlike wall time they hold when other people's builds share the 2 cores.
template <typename F>
double cpu_ms(F&& f, clockid_t clock = CLOCK_THREAD_CPUTIME_ID) {
  timespec a{}, b{};
  clock_gettime(clock, &a);
  f();
  clock_gettime(clock, &b);
  return (b.tv_sec - a.tv_sec) * 1e3 + (b.tv_nsec - a.tv_nsec) / 1e6;
}

}  // namespace rgbdcast::bench
