#include "service/image_header.h"

#include <cstring>

namespace rgbdcast::service {
namespace {

unsigned be32(const unsigned char* p) {
  return (unsigned{p[0]} << 24) | (unsigned{p[1]} << 16) | (unsigned{p[2]} << 8) | unsigned{p[3]};
}
unsigned be16(const unsigned char* p) { return (unsigned{p[0]} << 8) | unsigned{p[1]}; }

Error bad(const char* what) { return make_error(ErrorCode::kInvalidInput, what); }

}  // namespace

Result<ImageSize> peek_image_size(const unsigned char* data, size_t size) {
  static const unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (size >= 8 && std::memcmp(data, kPng, 8) == 0) {
    if (size < 24 || std::memcmp(data + 12, "IHDR", 4) != 0) return bad("PNG without an IHDR header");
    const unsigned w = be32(data + 16), h = be32(data + 20);
    if (w == 0 || h == 0 || w > (1u << 30) || h > (1u << 30)) return bad("PNG header gives an invalid size");
    return ImageSize{static_cast<int>(w), static_cast<int>(h), "png"};
  }
  if (size >= 3 && data[0] == 0xff && data[1] == 0xd8 && data[2] == 0xff) {
    size_t p = 2;
    while (p + 4 <= size) {
      if (data[p] != 0xff) return bad("JPEG marker expected");
      const unsigned char marker = data[p + 1];
      if (marker == 0xff) {  // fill byte
        ++p;
        continue;
      }
      if (marker == 0xd8 || (marker >= 0xd0 && marker <= 0xd7) || marker == 0x01) {  // no length
        p += 2;
        continue;
      }
      const unsigned len = be16(data + p + 2);
      if (len < 2) return bad("JPEG segment length under 2");
      const bool sof = marker >= 0xc0 && marker <= 0xcf && marker != 0xc4 && marker != 0xc8 && marker != 0xcc;
      if (sof) {
        if (p + 9 > size || len < 7) return bad("JPEG frame header cut short");
        const unsigned h = be16(data + p + 5), w = be16(data + p + 7);
        if (w == 0 || h == 0) return bad("JPEG frame header gives an invalid size");
        return ImageSize{static_cast<int>(w), static_cast<int>(h), "jpeg"};
      }
      if (marker == 0xd9 || marker == 0xda) return bad("JPEG without a frame header before its data");
      p += 2 + len;
    }
    return bad("JPEG frame header not found");
  }
  return bad("not a PNG or JPEG image");
}

}  // namespace rgbdcast::service
