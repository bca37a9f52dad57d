// The libFuzzer entry point, compiled once per target with -DRGBDCAST_FUZZ_TARGET=<name> (fuzz/CMakeLists.txt).
#include "fuzz/fuzz_targets.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, size_t size) {
  rgbdcast::fuzz::RGBDCAST_FUZZ_TARGET(data, size);
  return 0;
}
