#pragma once
// What a view of a live mission draws: the tiles its committed tileset selects for the camera by screen-space error
// (tiles/tile_selection.h), and the keyframes that tileset does not hold yet (posted after its version, or revised
// since), each drawn whole, so a view never waits for the tile worker. Contract:
// - Parts are keyed under mission_scene_key(name) + "/": "tile/<file>" (immutable files) and
//   "keyframe/<seq>-<rev>"; RenderPool::forget(mission_scene_key(name)) drops them all.
// - At most max_pending of the keyframes the tileset lacks are drawn, the highest seqs; the rest are counted (a
//   restart with a long mission whose tileset is still being opened draws its newest keyframes, not all of them).
// - The camera's far plane is pushed out to the farthest selected tile (overviews of a large floor).
// - A tile file retired between the selection and its loading is left out of the view (RenderOutput::parts_missing).
// - fit_bytes > 0 bounds the view: tiles that would take more than fit_bytes on a renderer are selected again at a
//   coarser error (tiles::select_tiles_to_fit, up to kMaxMaxErrorPx), so a view of a long mission draws coarser
//   tiles instead of loading its parts again for every view (a renderer keeps at most its share of the resident
//   cap). When no error up to kMaxMaxErrorPx fits (a camera inside tiles' boxes refines them at any error), the
//   tiles are refined by largest error first while they fit (tiles::select_tiles_within). The error used is
//   reported (MissionViewPlan::max_error_px; kMaxMaxErrorPx in that case).
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "scene/camera.h"
#include "scene/result.h"
#include "service/mission_store.h"
#include "service/mission_tiles.h"
#include "service/render_pool.h"

namespace rgbdcast::service {

inline constexpr double kDefaultMaxErrorPx = 1.0;
inline constexpr double kMaxMaxErrorPx = 1000.0;
inline constexpr size_t kMaxPendingKeyframes = 64;

struct MissionViewPlan {
  std::vector<ViewPart> parts;
  ViewCamera camera;
  std::uint64_t tileset_version = 0;  // 0: no tileset yet
  double max_error_px = 0.0;          // the screen-space error the tiles were selected at
  size_t tiles = 0, pending = 0, pending_left_out = 0;
  size_t stale_tiles = 0;  // the tileset's inner tiles still to be rebuilt: drawn from their descendants meanwhile
  std::uint64_t tile_triangles = 0;
};

// `keyframes` is the mission's current listing (MissionStore::keyframes), `camera` the view's.
MissionViewPlan plan_mission_view(const MissionStore& store, const MissionTiles& tiles, const std::string& name,
                                  const std::vector<MissionKeyframe>& keyframes, const ViewCamera& camera,
                                  double max_error_px, size_t fit_bytes = 0, size_t max_pending = kMaxPendingKeyframes);

}  // namespace rgbdcast::service
