#pragma once
// Frame-rate work allocates and frees the same few megabytes for every frame (depth grids, the hierarchy's
// per-triangle arrays, texture copies, encoder buffers). glibc hands blocks above its mmap threshold back to the
// kernel when they are freed and trims the heap above 128 kB, so each frame page-faults its memory in again: on TUM
// fr1/xyz 200-319 frame 0 that was a quarter of the realtime preset's CPU time (67 -> 51 ms a frame single-threaded,
// `perf stat` over 20 frames of bench/reduce_bench). keep_freed_frame_memory() keeps freed memory in the heap for
// the next frame instead.
//
// It is a process-wide setting, so only program entry points that reduce frames in a loop call it (`rgbdcast
// reduce`, `rgbdcast stream`, the benches), never a library. `rgbdcast serve` does not call it: ViewService::create
// (service/view_service.cpp) owns the server's malloc settings (two arenas, 2 MB mmap and 16 MB trim thresholds,
// with malloc_trim after bursts of views). MALLOC_MMAP_THRESHOLD_ / MALLOC_TRIM_THRESHOLD_ in the environment win.
#include <malloc.h>

#include <cstdlib>

namespace rgbdcast {

inline void keep_freed_frame_memory() {
  if (!std::getenv("MALLOC_MMAP_THRESHOLD_")) ::mallopt(M_MMAP_THRESHOLD, 64 << 20);
  if (!std::getenv("MALLOC_TRIM_THRESHOLD_")) ::mallopt(M_TRIM_THRESHOLD, 256 << 20);
}

}  // namespace rgbdcast
