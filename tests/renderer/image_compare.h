#pragma once
// Golden-image comparison (after Filament's renderdiff): a pixel matches when some offset within +-max_shift_px
// gives a pixel of the other image whose channels all differ by <= tolerance; the images agree when at most
// max_bad_fraction of the pixels do not match. PNG I/O through stb, for tests only.
#include <string>

#include "scene/image.h"

namespace rgbdcast::test {

struct CompareResult {
  bool same_size = false;
  long bad_pixels = 0;
  double bad_fraction = 1.0;
  Image diff;  // RGB: grey copy of expected, bad pixels in red
  bool pass(double max_bad_fraction = 0.001) const { return same_size && bad_fraction <= max_bad_fraction; }
};

CompareResult compare_images(const Image& actual, const Image& expected, int tolerance = 5, int max_shift_px = 1);

// PNG of any 3/4-channel Image; written to a temporary name then renamed. False on failure.
bool write_png(const std::string& path, const Image& image);
// Empty Image when the file cannot be read.
Image read_png(const std::string& path);

// Compares `actual` with tests/renderer/golden/<name>.png. On failure (or a missing golden) writes
// <build>/tests/renderer/golden/<name>.actual.png, .diff.png and .expected.png and returns a message saying where;
// returns "" on success.
std::string check_golden(const std::string& name, const Image& actual);

}  // namespace rgbdcast::test
