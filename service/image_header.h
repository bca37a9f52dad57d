#pragma once
// The pixel size of an encoded PNG or JPEG, read from its header without decoding (IHDR; the first SOFn marker),
// so an upload can be refused before a decoder allocates width*height*channels bytes. Other formats, and headers
// that are cut short or malformed, are kInvalidInput. Safe on untrusted input: reads only inside `size`.
#include <cstddef>

#include "scene/result.h"

namespace rgbdcast::service {

struct ImageSize {
  int width = 0, height = 0;
  const char* format = "";  // "png" or "jpeg"
};

Result<ImageSize> peek_image_size(const unsigned char* data, size_t size);

}  // namespace rgbdcast::service
