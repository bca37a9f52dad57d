#pragma once
// sRGB bytes (captured colours) <-> linear values (glTF COLOR_0 is linear).
#include <cmath>
#include <cstdint>

namespace rgbdcast::glb {

inline std::uint16_t srgb8_to_linear16(std::uint8_t c) {
  const double s = c / 255.0;
  const double l = s <= 0.04045 ? s / 12.92 : std::pow((s + 0.055) / 1.055, 2.4);
  return static_cast<std::uint16_t>(std::lround(l * 65535.0));
}

inline std::uint8_t linear_to_srgb8(double l) {
  l = l < 0 ? 0 : (l > 1 ? 1 : l);
  const double s = l <= 0.0031308 ? 12.92 * l : 1.055 * std::pow(l, 1.0 / 2.4) - 0.055;
  return static_cast<std::uint8_t>(std::lround(s * 255.0));
}

}  // namespace rgbdcast::glb
