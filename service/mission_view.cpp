#include "service/mission_view.h"

#include <algorithm>
#include <filesystem>
#include <memory>

#include "base/atomic_file.h"
#include "gltf/gltf_io.h"
#include "service/mission_routes.h"  // mission_scene_key
#include "service/mission_scene.h"
#include "tiles/tile_selection.h"

namespace rgbdcast::service {
namespace {

constexpr size_t kMaxTileFileBytes = size_t(256) << 20;

Result<std::shared_ptr<const Scene>> load_tile(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return make_error(ErrorCode::kNotFound, "no tile file " + path);
  auto bytes = read_file_bytes(path, kMaxTileFileBytes);
  if (!bytes) return bytes.error();
  auto scene = decode_glb(bytes->data(), bytes->size());
  if (!scene) return make_error(ErrorCode::kInternal, "tile " + path + " does not decode: " + scene.error().message);
  return std::shared_ptr<const Scene>(std::make_shared<Scene>(std::move(*scene)));
}

// The distance from the camera's centre to the farthest corner of the box.
double farthest_corner(const Eigen::AlignedBox3d& box, const ViewCamera& camera) {
  const Eigen::Vector3d eye = camera.camera_to_world.block<3, 1>(0, 3);
  double d = 0.0;
  for (int i = 0; i < 8; ++i)
    d = std::max(d, (box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(i)) - eye).norm());
  return d;
}

}  // namespace

MissionViewPlan plan_mission_view(const MissionStore& store, const MissionTiles& tiles, const std::string& name,
                                  const std::vector<MissionKeyframe>& keyframes, const ViewCamera& camera,
                                  double max_error_px, size_t fit_bytes, size_t max_pending) {
  MissionViewPlan plan;
  plan.camera = camera;
  plan.max_error_px = max_error_px;
  const std::string prefix = mission_scene_key(name) + "/";
  auto snapshot = tiles.snapshot(name);
  if (snapshot && snapshot->version > 0) {
    plan.tileset_version = snapshot->version;
    // The far plane first: tiles beyond the default far plane would be culled by the selection.
    for (const auto& [key, r] : snapshot->records)
      if (key.level == snapshot->top_level)
        plan.camera.far_m = std::max(plan.camera.far_m, farthest_corner(r.box, camera));
    const tiles::TileSelection selection =
        tiles::select_tiles_to_fit(snapshot->records, snapshot->top_level, plan.camera, max_error_px, fit_bytes,
                                   kMaxMaxErrorPx, &plan.max_error_px);
    for (const tiles::TileRecord* r : selection.tiles) {
      const std::string file = r->file();
      // A tile file stays on disk for one more version after it is replaced (tiles/tile_hierarchy.h); a view that
      // loads it later than that leaves it out.
      plan.parts.push_back({prefix + "tile/" + file, [&tiles, name, file]() -> Result<std::shared_ptr<const Scene>> {
                              auto path = tiles.tile_file(name, file);
                              if (!path) return path.error();
                              return load_tile(*path);
                            }});
    }
    plan.tiles = selection.tiles.size();
    plan.stale_tiles = snapshot->stale;
    plan.tile_triangles = selection.triangles;
  }
  std::vector<const MissionKeyframe*> pending;
  for (const MissionKeyframe& k : keyframes) {
    if (snapshot && snapshot->version > 0) {
      auto it = snapshot->keyframes.find(k.seq);
      if (it != snapshot->keyframes.end() && it->second == k.rev) continue;
    }
    pending.push_back(&k);
  }
  std::sort(pending.begin(), pending.end(), [](auto* a, auto* b) { return a->seq > b->seq; });
  if (pending.size() > max_pending) {
    plan.pending_left_out = pending.size() - max_pending;
    pending.resize(max_pending);
  }
  for (const MissionKeyframe* k : pending) {
    MissionKeyframe copy = *k;
    copy.mission = name;
    plan.parts.push_back({prefix + "keyframe/" + std::to_string(k->seq) + "-" + std::to_string(k->rev),
                          [&store, copy]() -> Result<std::shared_ptr<const Scene>> {
                            auto placed = load_placed_keyframe(store, copy);
                            if (!placed) return placed.error();
                            return std::shared_ptr<const Scene>(std::make_shared<Scene>(std::move(*placed)));
                          }});
  }
  plan.pending = pending.size();
  return plan;
}

}  // namespace rgbdcast::service
