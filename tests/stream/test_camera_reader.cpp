// The camera reader of `rgbdcast stream` (stream/camera_reader.h) on real TUM frames: one frame ahead of the tracker,
// in order; in realtime a tracker slower than the camera gets the newest frame due and the ones it missed are
// counted as dropped, never handed over late and never decoded.
#include <gtest/gtest.h>

#include <chrono>
#include <optional>
#include <thread>

#include "input/frame_source.h"
#include "stream/camera_reader.h"
#include "tests/common/test_data.h"

namespace rgbdcast::stream {
namespace {

const char* kTum = "tum/rgbd_dataset_freiburg1_xyz_200_319";

double steady_now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

TEST(CameraReader, AsFastAsTheTrackerTakesThemEveryFrameComesInOrder) {
  REQUIRE_DATA(kTum);
  auto source = open_frame_source(test::data_path(kTum), SourceOptions{});
  ASSERT_TRUE(source) << source.error().message;
  std::mutex source_mu;
  CameraReaderOptions o;
  o.from = 3;
  o.last = 12;
  o.steady_s = [] { return 42.0; };  // the runtime's clock, held still
  CameraReader reader(**source, o, source_mu);
  for (size_t i = o.from; i <= o.last; ++i) {
    auto f = reader.take(i);
    ASSERT_TRUE(f) << i << ": " << f.error().message;
    EXPECT_EQ(f->frame.index, static_cast<int>(i));
    EXPECT_EQ(f->frame.depth_m.cols, 640);
    EXPECT_GT(f->read_cpu_ms, 0.0);
    EXPECT_GT(f->captured, 1.5e9);  // Unix seconds of the read
    EXPECT_EQ(f->began_s, 42.0);    // on the clock it was given
    std::this_thread::sleep_for(std::chrono::milliseconds(20));  // a tracker's work
  }
  EXPECT_EQ(reader.dropped(), 0u);
  EXPECT_FALSE(reader.take(o.last + 1));  // past the range: not handed over
}

TEST(CameraReader, InRealtimeASlowTrackerGetsTheNewestFrameAndTheMissedOnesAreDropped) {
  REQUIRE_DATA(kTum);
  auto source = open_frame_source(test::data_path(kTum), SourceOptions{});
  ASSERT_TRUE(source) << source.error().message;
  const auto& entries = (*source)->entries();
  std::mutex source_mu;
  CameraReaderOptions o;
  o.realtime = true;
  o.from = 0;
  o.last = 29;  // about 1 s of frames at 30 Hz
  CameraReader reader(**source, o, source_mu);
  size_t taken = 0, dropped = 0;
  double first_captured = 0;
  std::optional<double> last_take_s;  // just before the last frame handed over was taken (the reader's clock)
  for (size_t i = o.from; i <= o.last; ++i) {
    const double before_take_s = steady_now_s();
    auto f = reader.take(i);
    if (!f) {
      EXPECT_NE(f.error().message.find("dropped"), std::string::npos) << f.error().message;
      ++dropped;
      continue;
    }
    ++taken;
    EXPECT_EQ(f->frame.index, static_cast<int>(i));
    if (first_captured == 0) first_captured = f->captured - (entries[i].color_timestamp - entries[0].color_timestamp);
    // captured is the frame's due time: its own timestamp on the run's clock.
    EXPECT_NEAR(f->captured - first_captured, entries[i].color_timestamp - entries[0].color_timestamp, 1e-3);
    // Not a backlog of old frames: the reader picks the next frame once the tracker took the last one, and picks
    // the newest already due, so the frame after this one was not yet due when the last one was taken (an order
    // of the reader's own clock, however slow the machine).
    if (last_take_s && i < o.last) {
      const double next_due_after_take_s =
          f->began_s - *last_take_s + (entries[i + 1].color_timestamp - entries[i].color_timestamp);
      EXPECT_GT(next_due_after_take_s, -1e-6) << i;
    }
    last_take_s = before_take_s;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));  // a tracker three times slower than the camera
  }
  EXPECT_EQ(reader.dropped(), dropped);
  EXPECT_EQ(taken + dropped, 30u);
  // It kept pace with the camera's clock instead of falling behind it: 1 s at 0.1 s per frame, about 10 taken (a
  // slower machine takes fewer, never more).
  EXPECT_GE(dropped, 15u);
  EXPECT_LE(taken, 14u);
}

}  // namespace
}  // namespace rgbdcast::stream
