// libFuzzer: the multipart frame upload up to (not including) the reduction: intrinsics JSON, colour and depth bytes
// -> parse_intrinsics_json, decode_color, decode_depth16, make_frame. Input framing (seeds in corpus/): two
// little-endian u32 lengths, the intrinsics text and the colour bytes, then the rest is the depth bytes.
#include <cstdint>
#include <string_view>
#include <vector>

#include "input/frame_source.h"
#include "input/intrinsics_io.h"

namespace {
std::uint32_t le32(const std::uint8_t* p) {
  return std::uint32_t(p[0]) | (std::uint32_t(p[1]) << 8) | (std::uint32_t(p[2]) << 16) | (std::uint32_t(p[3]) << 24);
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, size_t size) {
  if (size < 8) return 0;
  const size_t n_json = le32(data), n_color = le32(data + 4);
  const size_t rest = size - 8;
  if (n_json > rest || n_color > rest - n_json) return 0;
  const std::uint8_t* p = data + 8;
  auto k = rgbdcast::parse_intrinsics_json(std::string_view(reinterpret_cast<const char*>(p), n_json), "intrinsics");
  const std::vector<unsigned char> color_bytes(p + n_json, p + n_json + n_color);
  const std::vector<unsigned char> depth_bytes(p + n_json + n_color, data + size);
  auto color = rgbdcast::decode_color(color_bytes, "color");
  auto depth = rgbdcast::decode_depth16(depth_bytes, "depth");
  if (k.ok() && color.ok() && depth.ok()) (void)rgbdcast::make_frame(*color, *depth, *k);
  return 0;
}
