#pragma once
// The camera's side of `rgbdcast stream`: a thread that reads (decodes, undistorts) the source's frames in order and
// hands them to the tracker one at a time, as a live camera's driver does, so that in realtime reading frame i+1
// overlaps tracking frame i (decoding a TUM frame's two PNGs is 11-14 ms, about 40 % of a frame's CPU here).
//
// Realtime: the reader stays one frame ahead: it reads the next frame once the tracker has taken the last one, into
// a one-frame slot. frame i is due at start + (t_i - t_first) on the reader's clock (t from the source's
// timestamps, else i / fps); the reader reads the newest frame already due (or waits on the clock for the next
// one), and the frames it passed over are dropped (counted), as a driver replaces a frame the application did not
// take in time. They are not decoded: here "reading" is decoding PNGs from disk, which a live camera does not cost,
// so decoding frames nobody takes would only steal CPU from the tracker. "captured" is the due time. Otherwise a
// frame is read when the tracker asks for it (no look-ahead: the tracker then waits for each keyframe's reduction,
// and a prefetched frame would age in the slot meanwhile), nothing is dropped, and "captured" is when its read
// started.
//
// take(i) is called with increasing i (the tracker's frame loop): it returns frame i, or kUnavailable ("dropped: ...")
// when the reader has already moved past it, or the source's error for it. The source is read under `source_mu`,
// which whoever else reads the same source (the reduction thread reloading a frame) must hold too: a FrameSource
// is not promised to be thread-safe. Thread-safety: take() from one thread; stop() from any.
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <functional>
#include <mutex>
#include <optional>
#include <thread>

#include "input/frame_source.h"
#include "stream/clock.h"

namespace rgbdcast::stream {

struct CameraReaderOptions {
  bool realtime = false;
  double fps_without_timestamps = 30;
  size_t from = 0, last = 0;  // the frames read: from..last (inclusive)
  // The reader's clock: it paces the frames on it (realtime) and stamps CameraFrame::began_s with it; the stream
  // runtime's (StreamOptions::clock); null: the system's. Must outlive the reader.
  Clock* clock = nullptr;
  // CameraFrame::captured's clock (Unix s, a wall-clock fact for the records): the runtime's; empty: the system's.
  std::function<double()> unix_s;
};

struct CameraFrame {
  RgbdFrame frame;
  double captured = 0;     // Unix s
  double began_s = 0;      // on the clock, s: due (realtime) or when its read started
  double read_cpu_ms = 0;  // the reader thread's CPU time for it
};

class CameraReader {
 public:
  CameraReader(const FrameSource& source, const CameraReaderOptions& options, std::mutex& source_mu);
  ~CameraReader();
  CameraReader(const CameraReader&) = delete;
  CameraReader& operator=(const CameraReader&) = delete;

  Result<CameraFrame> take(size_t i);
  void stop();  // take() then returns kUnavailable; returns once the thread ended
  size_t dropped() const;

 private:
  void run();
  double stamp(size_t i) const;

  const FrameSource& source_;
  CameraReaderOptions options_;
  Clock& clock_;
  std::mutex& source_mu_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  // The slot: the newest frame read and not yet taken (index, and the frame or its read error).
  std::optional<size_t> slot_index_;
  std::optional<Result<CameraFrame>> slot_;
  size_t next_to_read_ = 0;       // the reader's position: frames below it were read or passed over
  std::optional<size_t> wanted_;  // the frame the tracker last asked for
  bool finished_ = false, stopping_ = false;
  size_t dropped_ = 0;
  std::thread thread_;
};

}  // namespace rgbdcast::stream
