// The camera reader of `rgbdcast stream` (stream/camera_reader.h) on real TUM frames: one frame ahead of the tracker,
// in order; in realtime a tracker slower than the camera gets the newest frame due and the ones it missed are
// counted as dropped, never handed over late and never decoded. On a manual clock (stream/clock.h) and an
// in-memory source the same rules are checked at exact clock times, without sleeping.
#include <gtest/gtest.h>

#include <chrono>
#include <optional>
#include <set>
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
  ManualClock clock;  // the runtime's clock, held still
  o.clock = &clock;
  CameraReader reader(**source, o, source_mu);
  for (size_t i = o.from; i <= o.last; ++i) {
    auto f = reader.take(i);
    ASSERT_TRUE(f) << i << ": " << f.error().message;
    EXPECT_EQ(f->frame.index, static_cast<int>(i));
    EXPECT_EQ(f->frame.depth_m.cols, 640);
    EXPECT_GT(f->read_cpu_ms, 0.0);
    EXPECT_GT(f->captured, 1.5e9);                               // Unix seconds of the read
    EXPECT_EQ(f->began_s, clock.now_s());                        // on the clock it was given
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

// Frames at 30 Hz from t = 1000 s, 2 x 2 pixels; remembers which frames were read (decoded).
class ClockedSource : public FrameSource {
 public:
  explicit ClockedSource(size_t n) {
    for (size_t i = 0; i < n; ++i) {
      FrameEntry e;
      e.color_timestamp = e.depth_timestamp = 1000.0 + static_cast<double>(i) / 30.0;
      entries_.push_back(e);
    }
  }
  std::string kind() const override { return "clocked"; }
  size_t size() const override { return entries_.size(); }
  const Intrinsics& intrinsics() const override { return intrinsics_; }
  Result<RgbdFrame> frame(size_t i) const override {
    if (i >= entries_.size()) return make_error(ErrorCode::kNotFound, "past the end");
    std::lock_guard lock(mu_);
    read_.insert(i);
    RgbdFrame f;
    f.color_rgb = cv::Mat(2, 2, CV_8UC3, cv::Scalar(0, 0, 0));
    f.depth_m = cv::Mat(2, 2, CV_32FC1, cv::Scalar(1.0));
    f.timestamp = entries_[i].color_timestamp;
    f.index = static_cast<int>(i);
    return f;
  }
  const std::vector<FrameEntry>& entries() const override { return entries_; }
  std::string root() const override { return "memory"; }
  std::set<size_t> read() const {
    std::lock_guard lock(mu_);
    return read_;
  }

 private:
  std::vector<FrameEntry> entries_;
  Intrinsics intrinsics_;
  mutable std::mutex mu_;
  mutable std::set<size_t> read_;
};

TEST(CameraReader, InRealtimeEachFrameIsReadAtItsDueTimeOnTheClockAndALateTrackerGetsTheNewest) {
  ClockedSource source(6);
  std::mutex source_mu;
  ManualClock clock;
  const Clock::time_point t0 = clock.now();
  auto due = [&](size_t i) {
    return t0 + Clock::from_seconds(source.entries()[i].color_timestamp - source.entries()[0].color_timestamp);
  };
  CameraReaderOptions o;
  o.realtime = true;
  o.from = 0;
  o.last = 5;
  o.clock = &clock;
  o.unix_s = [] { return 2e9; };
  CameraReader reader(source, o, source_mu);

  auto f = reader.take(0);  // due at the start
  ASSERT_TRUE(f) << f.error().message;
  EXPECT_EQ(f->frame.index, 0);
  EXPECT_EQ(f->began_s, clock.seconds(t0));
  EXPECT_EQ(f->captured, 2e9);
  // The reader sleeps until frame 1 is due, and has not read it.
  EXPECT_EQ(clock.next_deadline(), due(1));
  EXPECT_EQ(source.read(), (std::set<size_t>{0}));
  clock.set(due(1));
  f = reader.take(1);
  ASSERT_TRUE(f) << f.error().message;
  EXPECT_EQ(f->frame.index, 1);
  EXPECT_EQ(f->began_s, clock.seconds(due(1)));
  EXPECT_NEAR(f->captured - 2e9, 1.0 / 30.0, 1e-6);  // its due time on the Unix clock of the start

  // A tracker 3.5 frames late: frames 2 and 3 are passed over (dropped, never read), frame 4 is handed over,
  // stamped with its own due time.
  EXPECT_EQ(clock.next_deadline(), due(2));
  clock.set(due(4) + (due(5) - due(4)) / 2);
  EXPECT_FALSE(reader.take(2));
  auto dropped = reader.take(3);
  ASSERT_FALSE(dropped);
  EXPECT_NE(dropped.error().message.find("dropped"), std::string::npos) << dropped.error().message;
  f = reader.take(4);
  ASSERT_TRUE(f) << f.error().message;
  EXPECT_EQ(f->frame.index, 4);
  EXPECT_EQ(f->began_s, clock.seconds(due(4)));
  EXPECT_EQ(reader.dropped(), 2u);

  EXPECT_EQ(clock.next_deadline(), due(5));
  clock.set(due(5));
  f = reader.take(5);
  ASSERT_TRUE(f) << f.error().message;
  EXPECT_EQ(f->began_s, clock.seconds(due(5)));
  EXPECT_EQ(source.read(), (std::set<size_t>{0, 1, 4, 5}));
  EXPECT_FALSE(reader.take(6));  // past the range
}

TEST(CameraReader, WithoutRealtimeAFrameIsReadWhenAskedForAndStampedWithTheClockThen) {
  ClockedSource source(3);
  std::mutex source_mu;
  ManualClock clock;
  CameraReaderOptions o;
  o.from = 0;
  o.last = 2;
  o.clock = &clock;
  CameraReader reader(source, o, source_mu);
  for (size_t i = 0; i <= 2; ++i) {
    auto f = reader.take(i);
    ASSERT_TRUE(f) << f.error().message;
    EXPECT_EQ(f->began_s, clock.now_s()) << i;
    EXPECT_EQ(source.read().size(), i + 1);  // no look-ahead
    clock.advance(std::chrono::seconds(1));  // a slow tracker drops nothing
  }
  EXPECT_EQ(reader.dropped(), 0u);
  EXPECT_EQ(clock.timed_waiters(), 0u);  // nothing paced on the clock
}

}  // namespace
}  // namespace rgbdcast::stream
