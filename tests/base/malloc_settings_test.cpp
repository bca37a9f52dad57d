#include "base/malloc_settings.h"

#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

namespace rgbdcast {
namespace {

TEST(MallocSettings, Profiles) {
  const MallocSettings frames = frame_loop_malloc_settings();
  EXPECT_EQ(frames.arena_max, 0);
  EXPECT_EQ(frames.mmap_threshold_bytes, 64u << 20);
  EXPECT_EQ(frames.trim_threshold_bytes, 256u << 20);
  const MallocSettings server = server_malloc_settings();
  EXPECT_EQ(server.arena_max, 2);
  EXPECT_EQ(server.mmap_threshold_bytes, 2u << 20);
  EXPECT_EQ(server.trim_threshold_bytes, 16u << 20);
}

TEST(MallocSettings, TheEnvironmentWins) {
  struct Case {
    std::vector<std::string> set;  // variables the environment sets
    int arena_max;
    size_t mmap, trim;
  };
  const Case cases[] = {
      {{}, 2, 2u << 20, 16u << 20},
      {{"MALLOC_ARENA_MAX"}, 0, 2u << 20, 16u << 20},
      {{"MALLOC_MMAP_THRESHOLD_"}, 2, 0, 16u << 20},
      {{"MALLOC_TRIM_THRESHOLD_"}, 2, 2u << 20, 0},
      {{"MALLOC_ARENA_MAX", "MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_"}, 0, 0, 0},
      {{"MALLOC_CHECK_"}, 2, 2u << 20, 16u << 20},
  };
  for (const Case& c : cases) {
    auto env = [&c](const char* name) -> const char* {
      for (const std::string& s : c.set)
        if (s == name) return "1";
      return nullptr;
    };
    const MallocSettings s = without_environment_overrides(server_malloc_settings(), env);
    EXPECT_EQ(s.arena_max, c.arena_max) << testing::PrintToString(c.set);
    EXPECT_EQ(s.mmap_threshold_bytes, c.mmap) << testing::PrintToString(c.set);
    EXPECT_EQ(s.trim_threshold_bytes, c.trim) << testing::PrintToString(c.set);
  }
}

}  // namespace
}  // namespace rgbdcast
