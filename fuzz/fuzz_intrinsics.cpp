// libFuzzer: parse_intrinsics_json on arbitrary text (the "intrinsics" part of a frame upload).
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "input/intrinsics_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, size_t size) {
  auto k = rgbdcast::parse_intrinsics_json(std::string_view(reinterpret_cast<const char*>(data), size));
  if (k.ok() && !(k->fx > 0 && k->fy > 0 && k->width >= 1 && k->height >= 1 && k->depth_scale > 0)) std::abort();
  return 0;
}
