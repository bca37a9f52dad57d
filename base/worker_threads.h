#pragma once
// Work split over plain threads that are started and joined within one call: the reduction's one thread model
// for its own parallel work (the depth filter's row bands, the RTIN's tiles, the budget's JPEG encodes and the
// work it runs beside a stage). Nothing outlives the call, nothing is shared between calls, and the caller's
// thread does a share itself, so one worker costs no thread. f must not throw (an exception on a started thread
// ends the process).
#include <algorithm>
#include <thread>
#include <utility>
#include <vector>

namespace rgbdcast {

// f(worker) for worker 0..workers-1: worker 0 on the calling thread, the others each on a thread of its own, all
// joined before it returns. workers < 1 counts as 1.
template <class F>
void run_workers(int workers, F&& f) {
  std::vector<std::thread> pool;
  for (int i = 1; i < workers; ++i) pool.emplace_back([&f, i] { f(i); });
  f(0);
  for (auto& t : pool) t.join();
}

// Rows 0..rows-1 in contiguous bands, one worker each: f(first_row, end_row, band) for band 0..bands-1, where
// bands = clamp(threads, 1, max(1, rows / min_band_rows)). The bands cover every row once, in order.
template <class F>
void for_row_bands(int rows, int threads, int min_band_rows, F&& f) {
  const int bands = std::clamp(threads, 1, std::max(1, rows / std::max(1, min_band_rows)));
  run_workers(bands, [&](int i) { f(rows * i / bands, rows * (i + 1) / bands, i); });
}

// `task` on a thread of its own while the caller goes on; joined by join() or, on every way out of the caller's
// scope, by the destructor. An empty task starts no thread.
class BesideThread {
 public:
  BesideThread() = default;
  template <class F>
  explicit BesideThread(F&& task) : thread_(std::forward<F>(task)) {}
  BesideThread(const BesideThread&) = delete;
  BesideThread& operator=(const BesideThread&) = delete;
  ~BesideThread() { join(); }
  // Starts `task` (after joining a task started before).
  template <class F>
  void start(F&& task) {
    join();
    thread_ = std::thread(std::forward<F>(task));
  }
  void join() {
    if (thread_.joinable()) thread_.join();
  }

 private:
  std::thread thread_;
};

}  // namespace rgbdcast
