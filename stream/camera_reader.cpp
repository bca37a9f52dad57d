#include "stream/camera_reader.h"

#include <time.h>

#include "base/stopwatch.h"

namespace rgbdcast::stream {

namespace {

double thread_cpu_ms() {
  timespec ts{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

}  // namespace

CameraReader::CameraReader(const FrameSource& source, const CameraReaderOptions& options, std::mutex& source_mu)
    : source_(source),
      options_(options),
      clock_(options.clock ? *options.clock : system_steady_clock()),
      source_mu_(source_mu),
      next_to_read_(options.from) {
  thread_ = std::thread([this] { run(); });
}

CameraReader::~CameraReader() { stop(); }

void CameraReader::stop() {
  {
    std::lock_guard lock(mu_);
    stopping_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

size_t CameraReader::dropped() const {
  std::lock_guard lock(mu_);
  return dropped_;
}

double CameraReader::stamp(size_t i) const {
  const auto& entries = source_.entries();
  const double t = i < entries.size() ? entries[i].color_timestamp : 0.0;
  return t > 0 ? t : static_cast<double>(i) / options_.fps_without_timestamps;
}

void CameraReader::run() {
  const std::function<double()> unix_s = options_.unix_s ? options_.unix_s : unix_seconds_now;
  const Clock::time_point start = clock_.now();
  const double start_unix = unix_s(), first = stamp(options_.from);
  auto due = [&](size_t i) { return start + Clock::from_seconds(stamp(i) - first); };
  for (size_t i = options_.from; i <= options_.last; ++i) {
    CameraFrame out;
    {
      std::unique_lock lock(mu_);
      cv_.wait(lock, [&] { return stopping_ || !slot_index_; });  // one frame ahead of the tracker, no more
      if (stopping_) break;
      if (options_.realtime) {
        // The newest frame already due; the ones before it are passed over (dropped) without being read. Again
        // after a wait: woken late (past the next frame's time), it reads the newest one, not a stale one.
        for (;;) {
          while (i < options_.last && clock_.now() >= due(i + 1)) ++i;
          next_to_read_ = i;
          cv_.notify_all();
          if (stopping_ || clock_.now() >= due(i)) break;
          clock_.wait_until(lock, cv_, due(i));
        }
        if (stopping_) break;
        out.captured = start_unix + (stamp(i) - first);
        out.began_s = clock_.seconds(due(i));
      } else {
        // On demand: the frame is read when the tracker asks for it, so that "captured" is not a frame's wait in
        // the slot while the tracker waited for a reduction (keyframe_stream.h).
        cv_.wait(lock, [&] { return stopping_ || (wanted_ && *wanted_ >= i); });
        if (stopping_) break;
        out.captured = unix_s();
        out.began_s = clock_.now_s();
      }
    }
    const double cpu0 = thread_cpu_ms();
    Result<RgbdFrame> frame = [&] {
      std::lock_guard lock(source_mu_);
      return source_.frame(i);
    }();
    out.read_cpu_ms = thread_cpu_ms() - cpu0;
    std::lock_guard lock(mu_);
    if (stopping_) break;
    slot_index_ = i;
    if (frame) {
      out.frame = std::move(*frame);
      slot_.emplace(std::move(out));
    } else {
      slot_.emplace(frame.error());
    }
    next_to_read_ = i + 1;
    cv_.notify_all();
  }
  std::lock_guard lock(mu_);
  finished_ = true;
  cv_.notify_all();
}

Result<CameraFrame> CameraReader::take(size_t i) {
  std::unique_lock lock(mu_);
  if (!wanted_ || *wanted_ < i) {
    wanted_ = i;
    cv_.notify_all();
  }
  for (;;) {
    if (stopping_) return make_error(ErrorCode::kUnavailable, "stopped");
    if (slot_index_ && *slot_index_ < i) {  // a frame the tracker did not ask for: never used
      slot_index_.reset();
      slot_.reset();
      cv_.notify_all();
    }
    if (slot_index_ && *slot_index_ == i) {
      Result<CameraFrame> out = std::move(*slot_);
      slot_index_.reset();
      slot_.reset();
      cv_.notify_all();  // the reader may wait for the slot to be empty
      return out;
    }
    if ((slot_index_ && *slot_index_ > i) || next_to_read_ > i || finished_) {
      ++dropped_;
      return make_error(ErrorCode::kUnavailable, "dropped: a newer frame was already due (behind the camera)");
    }
    cv_.wait(lock);
  }
}

}  // namespace rgbdcast::stream
