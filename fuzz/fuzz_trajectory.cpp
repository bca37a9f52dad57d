// libFuzzer: the trajectory parsers (TUM, Redwood .log, ICL-NUIM) on arbitrary text; the first byte picks the format.
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "keyframes/trajectory_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const auto format = static_cast<rgbdcast::TrajectoryFormat>(data[0] % 3);
  auto tr = rgbdcast::parse_trajectory(std::string_view(reinterpret_cast<const char*>(data + 1), size - 1), format);
  if (tr.ok()) {
    if (tr->poses.empty()) std::abort();
    for (const auto& p : tr->poses)
      if (!p.camera_to_world.allFinite()) std::abort();
  }
  return 0;
}
