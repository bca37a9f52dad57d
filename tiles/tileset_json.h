#pragma once
// The OGC 3D Tiles 1.1 tileset of a tile hierarchy. Frames: tile GLBs are glTF (y up; gltf/gltf_io.h turns the
// mission's OpenCV world into it), and 3D Tiles clients turn glTF y-up into the tileset's z-up frame, so a world point
// (x, y, z) (OpenCV: y down, z forward) is at (x, z, -y) in the tileset; bounding boxes are written in that frame.
// The root has no content and the top tiles as children; every tile refines by REPLACE.
#include <cstdint>
#include <map>
#include <string>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "tiles/tile_key.h"

namespace rgbdcast::tiles {

struct TileRecord;

// A 3D Tiles "box" (centre, then the three half-axes) of a world-frame box, in millimetres' precision: the centre
// rounded, the half-axes grown to still hold the box (a tileset of thousands of leaves is mostly boxes, and a full
// double takes 17 digits).
nlohmann::json tileset_box(const Eigen::AlignedBox3d& world_box);

// The tileset JSON: asset.version "1.1", asset.tilesetVersion the hierarchy version, content URIs
// content_prefix + TileRecord::file(). top_level: the level of the tiles under the root. Geometric errors are rounded
// up to 0.1 mm (rounding up keeps their order). A stale tile has no content and its parent's error.
nlohmann::json make_tileset(const std::map<TileKey, TileRecord>& tiles, int top_level, std::uint64_t version,
                            const std::string& content_prefix);

}  // namespace rgbdcast::tiles
