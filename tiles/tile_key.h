#pragma once
// Where a tile sits in a mission's quadtree. The tree lies over the floor of the mission's world frame (scene/camera.h:
// OpenCV axes, y down, so the floor is the x-z plane). Level 0 holds the leaves, square cells of leaf_size_m; a tile
// of level l covers 2^l x 2^l leaves, and its parent is at level l + 1. Cells are indexed by floor division, so
// negative coordinates work like positive ones and a mission can grow in any direction.
#include <compare>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace rgbdcast::tiles {

struct TileKey {
  int level = 0;
  std::int64_t x = 0, z = 0;  // cell index along world x and world z at this level

  auto operator<=>(const TileKey&) const = default;
  TileKey parent() const;
  // "<level>_<x>_<z>", e.g. "0_-3_12": what tile file names start with.
  std::string name() const;
};

// The inverse of TileKey::name(); nullopt for anything else (levels 0..62, |x|, |z| < 2^40).
std::optional<TileKey> parse_tile_key(std::string_view text);

// The leaf whose cell holds the floor point (x_m, z_m). leaf_size_m > 0; coordinates are clamped to +-2^40 cells.
TileKey leaf_key(double x_m, double z_m, double leaf_size_m);

}  // namespace rgbdcast::tiles
