// ReductionParams::threads caps every OpenMP region of the reduction, PCL's NormalEstimationOMP included (which on
// its own takes omp_get_num_procs() and ignores OMP_NUM_THREADS). Measured through the thread pool libgomp keeps for
// a thread after its parallel regions: a team of n leaves n - 1 pool threads in the process until the thread ends.
#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <chrono>
#include <thread>

#include "input/frame_source.h"
#include "reduction/openmp_threads.h"
#include "reduction/pipeline.h"
#include "tests/common/test_data.h"

namespace rgbdcast {
namespace {

const char* kFr1 = "tum/rgbd_dataset_freiburg1_xyz";

int process_threads() {
  int n = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator("/proc/self/task")) ++n;
  return n;
}

// Runs `work` on a fresh thread; returns how many threads the process gained while it ran (counted on that thread
// before it ends, so the OpenMP pool threads it started are still there). Stages that start plain threads join
// them, but a joined thread can still be listed in /proc for a moment after the join returns: the count is the
// least seen over 0.5 s, so what is counted is a pool that stays, not a thread on its way out.
int threads_left_by(const std::function<void()>& work) {
  int grown = -1;
  std::thread t([&] {
    const int before = process_threads();
    work();
    grown = process_threads() - before;
    for (int i = 0; i < 20 && grown > 0; ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(25));
      grown = std::min(grown, process_threads() - before);
    }
  });
  t.join();
  return grown;
}

Result<RgbdFrame> fr1_frame0() {
  SourceOptions o;
  o.intrinsics = "fr1";
  auto src = open_frame_source(test::data_path(kFr1), o);
  if (!src) return src.error();
  return (*src)->frame(0);
}

TEST(ReductionThreads, EveryParallelStageKeepsToTheCap) {
  REQUIRE_DATA(kFr1);
  auto frame = fr1_frame0();
  ASSERT_TRUE(frame) << frame.error().message;

  // Paper preset with the organized outlier search: normals (PCL's NormalEstimationOMP) and the organized statistic;
  // realtime preset: the depth mesh's moments. Both presets, each at `threads`.
  auto reduce_both = [&](int threads) {
    for (Preset preset : {Preset::kPaper, Preset::kRealtime}) {
      ReductionParams p = reduction_preset(preset);
      p.outlier_method = OutlierMethod::kOrganized;
      p.threads = threads;
      auto r = reduce_frame(*frame, p);
      ASSERT_TRUE(r) << r.error().message;
      EXPECT_GT(r->mesh.indices.size(), 3000u);
    }
  };
  threads_left_by([&] { reduce_both(1); });  // warm-up: libraries' own one-time pools (OpenCV's TBB arena)

  EXPECT_EQ(threads_left_by([&] { reduce_both(1); }), 0) << "a stage started OpenMP threads past threads = 1";
  // The measurement sees a pool: 3 threads asked for, 2 pool threads left (whatever the machine's core count).
  EXPECT_EQ(threads_left_by([&] { reduce_both(3); }), 2);
  EXPECT_EQ(openmp_threads(5), 5);
  EXPECT_GE(openmp_threads(0), 1);
}

TEST(ReductionThreads, TheSameMeshWhateverTheThreadCount) {
  REQUIRE_DATA(kFr1);
  auto frame = fr1_frame0();
  ASSERT_TRUE(frame) << frame.error().message;
  for (Preset preset : {Preset::kPaper, Preset::kRealtime}) {
    ReductionParams p = reduction_preset(preset);
    p.outlier_method = OutlierMethod::kOrganized;
    p.threads = 1;
    auto one = reduce_frame(*frame, p);
    p.threads = 2;
    auto two = reduce_frame(*frame, p);
    ASSERT_TRUE(one && two);
    EXPECT_EQ(one->mesh.indices, two->mesh.indices) << to_string(preset);
    EXPECT_EQ(one->mesh.positions.size(), two->mesh.positions.size()) << to_string(preset);
  }
  ReductionParams bad;
  bad.threads = -1;
  EXPECT_FALSE(bad.validate().ok());
}

}  // namespace
}  // namespace rgbdcast
