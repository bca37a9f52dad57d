#pragma once
// Where a tile sits in a mission's quadtree. The tree lies over the floor of the mission's world frame (scene/camera.h:
// OpenCV axes, y down, so the floor is the x-z plane). Level 0 is divided into square cells of leaf_size_m; a tile of
// level l >= 1 covers 2^l x 2^l of them, and its parent is at level l + 1. The leaves are keyframes: a leaf's key is
// its cell (where its surface's centroid lies) and its keyframe's seq, so a cell holds any number of leaves and its
// level-1 tile is their parent. Cells are indexed by floor division, so negative coordinates work like positive ones
// and a mission can grow in any direction.
#include <compare>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace rgbdcast::tiles {

struct TileKey {
  int level = 0;
  std::int64_t x = 0, z = 0;   // cell index along world x and world z at this level
  std::int64_t keyframe = -1;  // a leaf's keyframe seq (>= 0); -1 for a cell or an inner tile

  auto operator<=>(const TileKey&) const = default;
  TileKey parent() const;
  // "<level>_<x>_<z>", or "0_<x>_<z>_<keyframe>" for a leaf, e.g. "0_-3_12_57": what tile file names start with.
  std::string name() const;
};

// The inverse of TileKey::name(); nullopt for anything else (levels 0..62, |x|, |z| < 2^40, a keyframe only at level
// 0, 0..2^53).
std::optional<TileKey> parse_tile_key(std::string_view text);

// The level-0 cell that holds the floor point (x_m, z_m) (keyframe -1). leaf_size_m > 0; coordinates are clamped to
// +-2^40 cells.
TileKey leaf_key(double x_m, double z_m, double leaf_size_m);

}  // namespace rgbdcast::tiles
