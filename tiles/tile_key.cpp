#include "tiles/tile_key.h"

#include <charconv>
#include <cmath>

namespace rgbdcast::tiles {
namespace {

constexpr std::int64_t kMaxCell = std::int64_t(1) << 40;
constexpr std::int64_t kMaxSeq = std::int64_t(1) << 53;

std::int64_t floor_half(std::int64_t v) { return v >= 0 ? v / 2 : -((-v + 1) / 2); }

bool parse_int(std::string_view text, std::int64_t* out) {
  if (text.empty() || text.size() > 16) return false;
  if (text.size() > 1 && (text[0] == '0' || (text[0] == '-' && text[1] == '0'))) return false;  // one spelling each
  auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), *out);
  return ec == std::errc() && end == text.data() + text.size();
}

}  // namespace

TileKey TileKey::parent() const { return {level + 1, floor_half(x), floor_half(z)}; }

std::string TileKey::name() const {
  std::string n = std::to_string(level) + "_" + std::to_string(x) + "_" + std::to_string(z);
  if (keyframe >= 0) {  // appended: GCC 12 takes "_" + a temporary string for a restrict violation (bug 105651)
    n += '_';
    n += std::to_string(keyframe);
  }
  return n;
}

std::optional<TileKey> parse_tile_key(std::string_view text) {
  const size_t a = text.find('_');
  if (a == std::string_view::npos) return std::nullopt;
  const size_t b = text.find('_', a + 1);
  if (b == std::string_view::npos) return std::nullopt;
  const size_t c = text.find('_', b + 1);
  std::int64_t level = 0;
  TileKey key;
  if (!parse_int(text.substr(0, a), &level) || !parse_int(text.substr(a + 1, b - a - 1), &key.x) ||
      !parse_int(text.substr(b + 1, c == std::string_view::npos ? std::string_view::npos : c - b - 1), &key.z))
    return std::nullopt;
  if (c != std::string_view::npos &&
      (level != 0 || !parse_int(text.substr(c + 1), &key.keyframe) || key.keyframe < 0 || key.keyframe > kMaxSeq))
    return std::nullopt;
  if (level < 0 || level > 62 || std::abs(key.x) >= kMaxCell || std::abs(key.z) >= kMaxCell) return std::nullopt;
  key.level = static_cast<int>(level);
  return key;
}

TileKey leaf_key(double x_m, double z_m, double leaf_size_m) {
  auto cell = [&](double v) {
    const double c = std::floor(v / leaf_size_m);
    if (!(c > -double(kMaxCell))) return -kMaxCell + 1;  // also NaN
    if (c >= double(kMaxCell)) return kMaxCell - 1;
    return static_cast<std::int64_t>(c);
  };
  return {0, cell(x_m), cell(z_m)};
}

}  // namespace rgbdcast::tiles
