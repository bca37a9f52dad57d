#include "tests/renderer/image_compare.h"

#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_image.h>
#include <stb/stb_image_write.h>

#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "tests/common/test_data.h"

namespace fs = std::filesystem;

namespace rgbdcast::test {

CompareResult compare_images(const Image& a, const Image& e, int tolerance, int max_shift_px) {
  CompareResult r;
  r.same_size = a.width == e.width && a.height == e.height && a.channels == e.channels && !a.empty();
  if (!r.same_size) return r;
  r.diff = Image::make(a.width, a.height, 3);
  auto close = [&](int x, int y, int ex, int ey) {
    const std::uint8_t* pa = a.pixel(x, y);
    const std::uint8_t* pe = e.pixel(ex, ey);
    for (int c = 0; c < a.channels; ++c)
      if (std::abs(int(pa[c]) - int(pe[c])) > tolerance) return false;
    return true;
  };
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      bool ok = close(x, y, x, y);
      for (int dy = -max_shift_px; dy <= max_shift_px && !ok; ++dy)
        for (int dx = -max_shift_px; dx <= max_shift_px && !ok; ++dx) {
          const int ex = x + dx, ey = y + dy;
          if (ex >= 0 && ey >= 0 && ex < a.width && ey < a.height) ok = close(x, y, ex, ey);
        }
      std::uint8_t* d = r.diff.pixel(x, y);
      const std::uint8_t* pe = e.pixel(x, y);
      const std::uint8_t grey = static_cast<std::uint8_t>((pe[0] + pe[1] + pe[2]) / 12);
      d[0] = ok ? grey : 255;
      d[1] = ok ? grey : 0;
      d[2] = ok ? grey : 0;
      if (!ok) ++r.bad_pixels;
    }
  r.bad_fraction = static_cast<double>(r.bad_pixels) / (static_cast<double>(a.width) * a.height);
  return r;
}

bool write_png(const std::string& path, const Image& image) {
  fs::create_directories(fs::path(path).parent_path());
  const std::string tmp = path + ".tmp";
  if (!stbi_write_png(tmp.c_str(), image.width, image.height, image.channels, image.data.data(),
                      image.width * image.channels))
    return false;
  std::error_code ec;
  fs::rename(tmp, path, ec);
  return !ec;
}

Image read_png(const std::string& path) {
  int w = 0, h = 0, n = 0;
  stbi_uc* px = stbi_load(path.c_str(), &w, &h, &n, 0);
  if (!px) return {};
  Image im = Image::make(w, h, n);
  std::copy(px, px + static_cast<size_t>(w) * h * n, im.data.begin());
  stbi_image_free(px);
  return im;
}

std::string check_golden(const std::string& name, const Image& actual) {
  const std::string golden = source_path("tests/renderer/golden/" + name + ".png");
  const std::string out = binary_path("tests/renderer/golden/" + name);
  const Image expected = read_png(golden);
  std::ostringstream msg;
  if (expected.empty()) {
    write_png(out + ".actual.png", actual);
    msg << "golden " << golden << " is missing; the actual image is " << out
        << ".actual.png (review it, then scripts/promote_goldens.sh " << name << ")";
    return msg.str();
  }
  const CompareResult r = compare_images(actual, expected);
  if (r.pass()) return "";
  write_png(out + ".actual.png", actual);
  write_png(out + ".expected.png", expected);
  if (r.same_size) write_png(out + ".diff.png", r.diff);
  msg << "image differs from golden " << golden << ": ";
  if (!r.same_size)
    msg << "size " << actual.width << "x" << actual.height << "x" << actual.channels << " vs " << expected.width << "x"
        << expected.height << "x" << expected.channels;
  else
    msg << r.bad_pixels << " pixels (" << 100.0 * r.bad_fraction << " %) beyond 5/255 with a 1-pixel shift";
  msg << "; see " << out << ".actual.png, .diff.png, .expected.png";
  return msg.str();
}

}  // namespace rgbdcast::test
