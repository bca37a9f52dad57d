#include "tiles/tileset_json.h"

#include <algorithm>

#include "tiles/tile_hierarchy.h"

namespace rgbdcast::tiles {
namespace {

nlohmann::json tile_json(const std::map<TileKey, TileRecord>& tiles, const TileRecord& r,
                         const std::string& content_prefix) {
  nlohmann::json t = {{"boundingVolume", {{"box", tileset_box(r.box)}}},
                      {"geometricError", r.geometric_error_m},
                      {"refine", "REPLACE"},
                      {"content", {{"uri", content_prefix + r.file()}}}};
  if (r.key.level > 0) {
    // Children: the four cells below, where present (the map is ordered by level, then x, then z).
    nlohmann::json children = nlohmann::json::array();
    for (std::int64_t dx = 0; dx < 2; ++dx)
      for (std::int64_t dz = 0; dz < 2; ++dz) {
        auto it = tiles.find(TileKey{r.key.level - 1, 2 * r.key.x + dx, 2 * r.key.z + dz});
        if (it != tiles.end()) children.push_back(tile_json(tiles, it->second, content_prefix));
      }
    if (!children.empty()) t["children"] = std::move(children);
  }
  return t;
}

}  // namespace

nlohmann::json tileset_box(const Eigen::AlignedBox3d& b) {
  if (b.isEmpty()) return {0, 0, 0, 0.001, 0, 0, 0, 0.001, 0, 0, 0, 0.001};
  const Eigen::Vector3d c = b.center(), h = 0.5 * (b.max() - b.min());
  return {c.x(), c.z(), -c.y(), h.x(), 0, 0, 0, h.z(), 0, 0, 0, h.y()};
}

nlohmann::json make_tileset(const std::map<TileKey, TileRecord>& tiles, int top_level, std::uint64_t version,
                            const std::string& content_prefix) {
  Eigen::AlignedBox3d all;
  double top_error = 0.0;
  nlohmann::json children = nlohmann::json::array();
  for (auto it = tiles.lower_bound(TileKey{top_level, INT64_MIN, INT64_MIN});
       it != tiles.end() && it->first.level == top_level; ++it) {
    all.extend(it->second.box);
    top_error = std::max(top_error, it->second.geometric_error_m);
    children.push_back(tile_json(tiles, it->second, content_prefix));
  }
  // The root has no content: its error only has to make every client refine it, at any distance that shows the
  // mission (its diagonal does).
  const double root_error = std::max(top_error, all.isEmpty() ? 1.0 : (all.max() - all.min()).norm());
  nlohmann::json root = {{"boundingVolume", {{"box", tileset_box(all)}}},
                         {"geometricError", root_error},
                         {"refine", "REPLACE"}};
  if (!children.empty()) root["children"] = std::move(children);
  return {{"asset", {{"version", "1.1"}, {"tilesetVersion", std::to_string(version)}, {"generator", "rgbdcast"}}},
          {"geometricError", root_error},
          {"root", std::move(root)}};
}

}  // namespace rgbdcast::tiles
