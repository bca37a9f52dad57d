#pragma once
// Which tiles of a mission's hierarchy a view draws: the 3D Tiles traversal with REPLACE refinement, by screen-space
// error. A tile's screen-space error is its geometric error projected at its nearest point to the camera,
// error_m * fy / distance, in pixels (the pinhole form of error * height / (2 * distance * tan(fovy / 2)) that 3D
// Tiles clients use). Contract:
// - From the top level down, a tile outside the view frustum is skipped with its subtree (its box lies wholly outside
//   one of the frustum's planes); a visible tile whose error is at most max_error_px, or a leaf, is drawn; any other
//   is replaced by its children. max_error_px = 0 draws the visible leaves: full detail.
// - A tile whose children are all absent is drawn itself (REPLACE needs something to replace it with).
// - A stale tile (tiles/tile_hierarchy.h) is never drawn: its children are visited instead.
// - A camera inside a tile's box has distance 0: that tile always refines.
#include <cstddef>
#include <map>
#include <vector>

#include "scene/camera.h"
#include "tiles/tile_hierarchy.h"

namespace rgbdcast::tiles {

struct TileSelection {
  std::vector<const TileRecord*> tiles;  // to draw, pointing into the records given
  size_t visited = 0, culled = 0;
  std::uint64_t triangles = 0, bytes = 0;  // of the tiles to draw (bytes: their GLB files)
  std::uint64_t render_bytes = 0;          // of the tiles to draw, as a renderer holds them
};

// The tiles `camera` draws at max_error_px (>= 0, finite). `records` is a committed hierarchy's (tile -> record),
// its top tiles at `top_level`.
TileSelection select_tiles(const std::map<TileKey, TileRecord>& records, int top_level, const ViewCamera& camera,
                           double max_error_px);

// The tiles `camera` draws at max_error_px, or coarser when they would take more than fit_bytes on a renderer (their
// records' render_bytes): the error is doubled (from at least 1 px, up to limit_px) and the tiles selected again
// until they fit. When even limit_px does not fit (a camera inside tiles' boxes refines them at any error), the
// selection is select_tiles_within(max_error_px, fit_bytes). *used_px gets the uniform error of the selection
// returned, limit_px for the last case. fit_bytes 0: no bound.
TileSelection select_tiles_to_fit(const std::map<TileKey, TileRecord>& records, int top_level, const ViewCamera& camera,
                                  double max_error_px, size_t fit_bytes, double limit_px, double* used_px);

// Refinement under a byte budget, in order of screen-space error (as point-cloud viewers fill a point budget): from
// the visible top tiles, the drawn tile with the largest error above max_error_px is replaced by its visible
// children when the drawn tiles' render_bytes stay within fit_bytes with them; otherwise it stays drawn. Among equal
// errors (infinite for a camera inside boxes) the coarser tile goes first. A stale tile is always replaced. The
// selection is over fit_bytes only when the visible top tiles (or the fresh tiles under stale ones) already are.
// With a budget that no refinement exceeds it draws what select_tiles(max_error_px) draws.
TileSelection select_tiles_within(const std::map<TileKey, TileRecord>& records, int top_level, const ViewCamera& camera,
                                  double max_error_px, size_t fit_bytes);

// Whether an axis-aligned world box can be seen by `camera` (some part of it inside the frustum, near to far), by the
// plane test: false only when all eight corners lie outside one plane. Conservative: may say true for a box beside
// the frustum's corner.
bool box_in_frustum(const Eigen::AlignedBox3d& box, const ViewCamera& camera);

// Euclidean distance from the camera's centre to the box (0 inside).
double distance_to_box(const Eigen::AlignedBox3d& box, const ViewCamera& camera);

}  // namespace rgbdcast::tiles
