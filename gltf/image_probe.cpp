#include "gltf/image_probe.h"

#include <algorithm>

namespace rgbdcast::glb {

bool probe_image_size(const std::uint8_t* d, size_t n, int* width, int* height) {
  static const std::uint8_t png[8] = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
  if (n >= 24 && std::equal(png, png + 8, d)) {
    *width = (d[16] << 24) | (d[17] << 16) | (d[18] << 8) | d[19];
    *height = (d[20] << 24) | (d[21] << 16) | (d[22] << 8) | d[23];
    return *width > 0 && *height > 0;
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

}  // namespace rgbdcast::glb
