// The entry point of every test program. A test program is a program entry point, so it owns the process-wide malloc
// settings (base/malloc_settings.h): it takes the frame-loop profile, as `rgbdcast reduce` and `rgbdcast stream` do,
// because most of the suite's CPU time is frames reduced or tracked in a loop. With glibc's defaults each frame's
// few megabytes were mapped and page-faulted in again: Tracking.TumExcerptPaperWindowAloneFallsShort took 42 CPU
// seconds (14 of them in the kernel) where it took 13.8 with the profile. The environment's MALLOC_* still win.
#include <gtest/gtest.h>

#include "base/malloc_settings.h"

int main(int argc, char** argv) {
  rgbdcast::apply_malloc_settings(rgbdcast::frame_loop_malloc_settings());
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
