#include "base/malloc_settings.h"

#include <malloc.h>

#include <cstdlib>

namespace rgbdcast {

MallocSettings frame_loop_malloc_settings() {
  MallocSettings s;
  s.mmap_threshold_bytes = size_t{64} << 20;
  s.trim_threshold_bytes = size_t{256} << 20;
  return s;
}

MallocSettings server_malloc_settings() {
  MallocSettings s;
  s.arena_max = 2;
  s.mmap_threshold_bytes = size_t{2} << 20;
  s.trim_threshold_bytes = size_t{16} << 20;
  return s;
}

MallocSettings without_environment_overrides(MallocSettings s, const std::function<const char*(const char*)>& env) {
  auto set = [&env](const char* name) { return (env ? env(name) : std::getenv(name)) != nullptr; };
  if (set("MALLOC_ARENA_MAX")) s.arena_max = 0;
  if (set("MALLOC_MMAP_THRESHOLD_")) s.mmap_threshold_bytes = 0;
  if (set("MALLOC_TRIM_THRESHOLD_")) s.trim_threshold_bytes = 0;
  return s;
}

void apply_malloc_settings(const MallocSettings& settings) {
  const MallocSettings s = without_environment_overrides(settings);
  if (s.arena_max > 0) ::mallopt(M_ARENA_MAX, s.arena_max);
  if (s.mmap_threshold_bytes > 0) ::mallopt(M_MMAP_THRESHOLD, static_cast<int>(s.mmap_threshold_bytes));
  if (s.trim_threshold_bytes > 0) ::mallopt(M_TRIM_THRESHOLD, static_cast<int>(s.trim_threshold_bytes));
}

void return_freed_heap() { ::malloc_trim(0); }

}  // namespace rgbdcast
