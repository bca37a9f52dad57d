#include "base/worker_threads.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

namespace rgbdcast {
namespace {

TEST(RunWorkers, EachWorkerRunsOnceAndWorkerZeroOnTheCaller) {
  for (int workers : {-1, 0, 1, 2, 5}) {
    std::vector<std::atomic<int>> runs(std::max(1, workers));
    std::thread::id zero;
    run_workers(workers, [&](int w) {
      ++runs[w];
      if (w == 0) zero = std::this_thread::get_id();
    });
    for (size_t w = 0; w < runs.size(); ++w) EXPECT_EQ(runs[w].load(), 1) << workers << " workers, worker " << w;
    EXPECT_EQ(zero, std::this_thread::get_id());
  }
}

TEST(RunWorkers, AllWorkersHaveFinishedWhenItReturns) {
  std::atomic<int> done{0};
  run_workers(4, [&](int w) {
    if (w > 0) std::this_thread::yield();
    ++done;
  });
  EXPECT_EQ(done.load(), 4);
}

TEST(ForRowBands, BandsCoverEveryRowOnceInOrder) {
  struct Case {
    int rows, threads, min_band_rows, bands;
  };
  const Case cases[] = {
      {480, 2, 32, 2}, {480, 1, 32, 1}, {480, 0, 32, 1}, {480, 64, 32, 15},
      {31, 4, 32, 1},  {0, 2, 32, 1},   {7, 3, 1, 3},    {10, 4, 0, 4},
  };
  for (const Case& c : cases) {
    std::mutex mu;
    std::vector<std::array<int, 3>> seen;  // first, end, band
    for_row_bands(c.rows, c.threads, c.min_band_rows, [&](int y0, int y1, int band) {
      std::lock_guard lock(mu);
      seen.push_back({y0, y1, band});
    });
    std::sort(seen.begin(), seen.end(), [](const auto& a, const auto& b) { return a[2] < b[2]; });
    ASSERT_EQ(static_cast<int>(seen.size()), c.bands) << c.rows << " rows, " << c.threads << " threads";
    int next = 0;
    for (size_t i = 0; i < seen.size(); ++i) {
      EXPECT_EQ(seen[i][2], static_cast<int>(i));
      EXPECT_EQ(seen[i][0], next);
      EXPECT_LE(seen[i][0], seen[i][1]);
      next = seen[i][1];
    }
    EXPECT_EQ(next, c.rows);
  }
}

TEST(BesideThread, RunsTheTaskAndJoinsOnEveryWayOut) {
  std::atomic<int> ran{0};
  {
    BesideThread side([&] { ++ran; });
  }
  EXPECT_EQ(ran.load(), 1);
  {
    BesideThread side;
    side.start([&] { ++ran; });
    side.join();
    EXPECT_EQ(ran.load(), 2);
    side.start([&] { ++ran; });
  }
  EXPECT_EQ(ran.load(), 3);
  auto throws = [&] {
    BesideThread side([&] { ++ran; });
    throw 1;
  };
  EXPECT_THROW(throws(), int);
  EXPECT_EQ(ran.load(), 4);
}

}  // namespace
}  // namespace rgbdcast
