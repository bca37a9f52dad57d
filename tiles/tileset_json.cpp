#include "tiles/tileset_json.h"

#include <algorithm>
#include <cmath>

#include "tiles/tile_hierarchy.h"

namespace rgbdcast::tiles {
namespace {

double rounded_error(double m) { return std::ceil(m * 1e4) / 1e4; }

// A stale tile (tiles/tile_hierarchy.h) has no content here and its parent's error, so every client refines through
// it (3DTilesRendererJS refines unconditionally a tile whose error is its parent's) to its fresh descendants.
nlohmann::json tile_json(const std::map<TileKey, TileRecord>& tiles, const TileRecord& r,
                         const std::string& content_prefix, double parent_error) {
  const double error = r.stale ? parent_error : rounded_error(r.geometric_error_m);
  nlohmann::json t = {
      {"boundingVolume", {{"box", tileset_box(r.box)}}}, {"geometricError", error}, {"refine", "REPLACE"}};
  if (!r.stale) t["content"] = {{"uri", content_prefix + r.file()}};
  nlohmann::json children = nlohmann::json::array();
  for (const TileRecord* c : children_of(tiles, r.key)) children.push_back(tile_json(tiles, *c, content_prefix, error));
  if (!children.empty()) t["children"] = std::move(children);
  return t;
}

}  // namespace

nlohmann::json tileset_box(const Eigen::AlignedBox3d& b) {
  if (b.isEmpty()) return {0, 0, 0, 0.001, 0, 0, 0, 0.001, 0, 0, 0, 0.001};
  const Eigen::Vector3d exact = b.center();
  const Eigen::Vector3d c = (exact * 1000.0).array().round() / 1000.0;
  const Eigen::Vector3d h =
      ((0.5 * (b.max() - b.min()) + (exact - c).cwiseAbs()) * 1000.0).array().ceil().max(1.0) / 1000.0;
  return {c.x(), c.z(), c.y() == 0.0 ? 0.0 : -c.y(), h.x(), 0, 0, 0, h.z(), 0, 0, 0, h.y()};
}

nlohmann::json make_tileset(const std::map<TileKey, TileRecord>& tiles, int top_level, std::uint64_t version,
                            const std::string& content_prefix) {
  Eigen::AlignedBox3d all;
  double top_error = 0.0;
  nlohmann::json children = nlohmann::json::array();
  std::vector<const TileRecord*> top;
  for (auto it = tiles.lower_bound(TileKey{top_level, INT64_MIN, INT64_MIN, INT64_MIN});
       it != tiles.end() && it->first.level == top_level; ++it) {
    all.extend(it->second.box);
    top_error = std::max(top_error, it->second.geometric_error_m);
    top.push_back(&it->second);
  }
  // The root has no content: its error only has to make every client refine it, at any distance that shows the
  // mission (its diagonal does).
  const double root_error = rounded_error(std::max(top_error, all.isEmpty() ? 1.0 : (all.max() - all.min()).norm()));
  for (const TileRecord* t : top) children.push_back(tile_json(tiles, *t, content_prefix, root_error));
  nlohmann::json root = {
      {"boundingVolume", {{"box", tileset_box(all)}}}, {"geometricError", root_error}, {"refine", "REPLACE"}};
  if (!children.empty()) root["children"] = std::move(children);
  return {{"asset", {{"version", "1.1"}, {"tilesetVersion", std::to_string(version)}, {"generator", "rgbdcast"}}},
          {"geometricError", root_error},
          {"root", std::move(root)}};
}

}  // namespace rgbdcast::tiles
