#pragma once
// An 8-bit image in plain memory: rows top to bottom, channels interleaved (RGB or RGBA). Shared by the atlas, the
// glTF reader/writer and the renderer, none of which need to agree on an image library.
#include <cstdint>
#include <vector>

namespace rgbdcast {

struct Image {
  int width = 0, height = 0, channels = 0;  // channels: 3 = RGB, 4 = RGBA
  std::vector<std::uint8_t> data;           // width * height * channels bytes

  bool empty() const { return width == 0 || height == 0 || data.empty(); }
  std::uint8_t* pixel(int x, int y) { return data.data() + (static_cast<size_t>(y) * width + x) * channels; }
  const std::uint8_t* pixel(int x, int y) const {
    return data.data() + (static_cast<size_t>(y) * width + x) * channels;
  }
  static Image make(int w, int h, int c) {
    Image im;
    im.width = w;
    im.height = h;
    im.channels = c;
    im.data.assign(static_cast<size_t>(w) * h * c, 0);
    return im;
  }
};

}  // namespace rgbdcast
