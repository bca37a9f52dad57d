// The golden comparison itself: 5/255 per channel, one-pixel shift, 0.1 % of pixels.
#include <gtest/gtest.h>

#include "tests/renderer/image_compare.h"

namespace rgbdcast::test {
namespace {

Image pattern(int shift_x) {
  Image im = Image::make(100, 50, 4);
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      std::uint8_t* p = im.pixel(x, y);
      const int xs = x - shift_x;  // stripes inside a margin, so a shift never meets the border
      const bool on = xs >= 10 && xs < 90 && (xs / 5) % 2 == 0;
      p[0] = on ? 200 : 10;
      p[1] = static_cast<std::uint8_t>(2 * y);
      p[2] = 77;
      p[3] = 255;
    }
  return im;
}

TEST(ImageCompare, ToleranceShiftAndFraction) {
  const Image a = pattern(0);
  EXPECT_EQ(compare_images(a, a).bad_pixels, 0);
  Image b = a;
  for (size_t i = 2; i < b.data.size(); i += 4) b.data[i] += 5;
  EXPECT_EQ(compare_images(b, a).bad_pixels, 0);
  for (size_t i = 2; i < b.data.size(); i += 4) b.data[i] += 1;  // now 6 off everywhere
  EXPECT_EQ(compare_images(b, a).bad_pixels, 100 * 50);
  // A one-pixel shift passes, two pixels do not (stripes are 5 pixels wide: 2 of every 5 columns move).
  EXPECT_TRUE(compare_images(pattern(1), a).pass());
  const CompareResult two = compare_images(pattern(2), a);
  EXPECT_FALSE(two.pass());
  EXPECT_GT(two.bad_fraction, 0.1);
  // 5 bad pixels of 5000 is 0.1 %: passes; 6 does not.
  Image c = a;
  for (int i = 0; i < 6; ++i) c.pixel(10 + 10 * i, 20)[1] = 255;
  EXPECT_FALSE(compare_images(c, a).pass());
  c.pixel(60, 20)[1] = a.pixel(60, 20)[1];
  EXPECT_EQ(compare_images(c, a).bad_pixels, 5);
  EXPECT_TRUE(compare_images(c, a).pass());
  EXPECT_FALSE(compare_images(Image::make(10, 10, 4), a).pass()) << "different sizes never pass";
}

}  // namespace
}  // namespace rgbdcast::test
