#pragma once
// glibc's malloc settings are process-wide, so they have one owner: program entry points pick a profile here and
// apply it once, before their threads start; no library sets them. Whatever the environment sets
// (MALLOC_ARENA_MAX, MALLOC_MMAP_THRESHOLD_, MALLOC_TRIM_THRESHOLD_) wins over the profile.
#include <cstddef>
#include <functional>

namespace rgbdcast {

// 0 in a field: leave glibc's default (or the environment's) alone.
struct MallocSettings {
  int arena_max = 0;
  size_t mmap_threshold_bytes = 0;
  size_t trim_threshold_bytes = 0;
};

// Programs that reduce frames in a loop (`rgbdcast reduce`, `rgbdcast stream`, the benches). Each frame allocates
// and frees the same few megabytes (depth grids, the hierarchy's per-triangle arrays, texture copies, encoder
// buffers); with glibc's defaults blocks above the mmap threshold go back to the kernel when freed and the heap is
// trimmed above 128 kB, so every frame page-faults its memory in again (a quarter of the realtime preset's CPU time
// on TUM fr1/xyz, single-threaded). A 64 MB mmap and a 256 MB trim threshold keep freed memory for the next frame.
MallocSettings frame_loop_malloc_settings();

// `rgbdcast serve`. Two arenas: with one per thread (up to 16 on 2 cores) a burst of large views leaves hundreds of
// MB spread over arenas that malloc_trim does not give back. A fixed 2 MB mmap threshold: glibc otherwise raises it
// to the largest mmapped block freed, after which view-sized buffers (render targets, readbacks, images, up to 64 MB)
// come from the heaps between long-lived allocations and stay resident; 2 MB rather than 128 kB because a keyframe
// POST allocates and frees the same 0.1-1.2 MB blocks each time, and mapping them anew cost most of a POST's time.
// A 16 MB trim threshold keeps those at the heap's top between POSTs; return_freed_heap() after a burst of views
// gives the rest back.
MallocSettings server_malloc_settings();

// `s` without the fields the environment sets: env(name) is the variable's value or null (std::getenv by default).
MallocSettings without_environment_overrides(MallocSettings s, const std::function<const char*(const char*)>& env = {});

// Applies the non-zero fields of without_environment_overrides(s) with mallopt.
void apply_malloc_settings(const MallocSettings& s);

// Gives freed heap memory back to the system (malloc_trim): after a burst of large allocations.
void return_freed_heap();

}  // namespace rgbdcast
