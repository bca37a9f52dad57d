#include "scene/image_probe.h"

#include <algorithm>

namespace rgbdcast {
namespace {

std::uint32_t be32(const std::uint8_t* p) {
  return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) | p[3];
}

}  // namespace

bool probe_image_size(const std::uint8_t* d, size_t n, int* width, int* height) {
  static const std::uint8_t png[8] = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
  if (d == nullptr) return false;
  if (n >= 24 && std::equal(png, png + 8, d)) {
    const std::uint32_t w = be32(d + 16), h = be32(d + 20);
    if (w == 0 || h == 0 || w > 0x7FFFFFFFu || h > 0x7FFFFFFFu) return false;
    *width = static_cast<int>(w);
    *height = static_cast<int>(h);
    return true;
  }
  if (n < 4 || d[0] != 0xFF || d[1] != 0xD8) return false;
  size_t pos = 2;
  while (pos + 4 <= n) {
    if (d[pos] != 0xFF) return false;
    const std::uint8_t marker = d[pos + 1];
    if (marker == 0xFF) {  // fill byte
      ++pos;
      continue;
    }
    if (marker == 0xD8 || (marker >= 0xD0 && marker <= 0xD7) || marker == 0x01) {
      pos += 2;
      continue;
    }
    const size_t len = (size_t(d[pos + 2]) << 8) | d[pos + 3];
    if (len < 2) return false;
    const bool sof = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
    if (sof) {
      if (pos + 9 > n) return false;
      *height = (d[pos + 5] << 8) | d[pos + 6];
      *width = (d[pos + 7] << 8) | d[pos + 8];
      return *width > 0 && *height > 0;
    }
    pos += 2 + len;
  }
  return false;
}

}  // namespace rgbdcast
