#include "tiles/tile_selection.h"

#include <array>
#include <cmath>

namespace rgbdcast::tiles {

bool box_in_frustum(const Eigen::AlignedBox3d& box, const ViewCamera& camera) {
  if (box.isEmpty()) return false;
  const Eigen::Matrix4d w2c = camera.world_to_camera();
  // Half-spaces in camera coordinates (x right, y down, z forward), each "inside" when >= 0: near, far, and the four
  // sides through the camera centre (u >= 0, u <= width, v >= 0, v <= height, multiplied through by z).
  const double w = camera.width, h = camera.height;
  const std::array<Eigen::Vector4d, 6> planes = {
      Eigen::Vector4d(0, 0, 1, -camera.near_m),    Eigen::Vector4d(0, 0, -1, camera.far_m),
      Eigen::Vector4d(camera.fx, 0, camera.cx, 0), Eigen::Vector4d(-camera.fx, 0, w - camera.cx, 0),
      Eigen::Vector4d(0, camera.fy, camera.cy, 0), Eigen::Vector4d(0, -camera.fy, h - camera.cy, 0)};
  std::array<Eigen::Vector4d, 8> corners;
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d c = box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(i));
    corners[i] = w2c * Eigen::Vector4d(c.x(), c.y(), c.z(), 1.0);
    corners[i].w() = 1.0;
  }
  for (const Eigen::Vector4d& p : planes) {
    bool all_out = true;
    for (const Eigen::Vector4d& c : corners)
      if (p.dot(c) >= 0.0) {
        all_out = false;
        break;
      }
    if (all_out) return false;
  }
  return true;
}

double distance_to_box(const Eigen::AlignedBox3d& box, const ViewCamera& camera) {
  const Eigen::Vector3d eye = camera.camera_to_world.block<3, 1>(0, 3);
  return std::sqrt(box.squaredExteriorDistance(eye));
}

namespace {

struct Traversal {
  const std::map<TileKey, TileRecord>& records;
  const ViewCamera& camera;
  double max_error_px;
  TileSelection out;

  void draw(const TileRecord& r) {
    out.tiles.push_back(&r);
    out.triangles += r.triangles;
    out.bytes += r.bytes;
    out.render_bytes += r.render_bytes;
  }

  void visit(const TileRecord& r) {
    ++out.visited;
    if (!box_in_frustum(r.box, camera)) {
      ++out.culled;
      return;
    }
    if (r.key.level == 0) return draw(r);
    if (!r.stale) {  // a stale tile's content lacks what changed below it: its fresh descendants are drawn instead
      const double d = distance_to_box(r.box, camera);
      const double sse_px = d > 0.0 ? r.geometric_error_m * camera.fy / d : INFINITY;
      if (sse_px <= max_error_px) return draw(r);
    }
    const auto children = children_of(records, r.key);
    if (children.empty() && !r.stale) return draw(r);
    for (const TileRecord* c : children) visit(*c);
  }
};

}  // namespace

TileSelection select_tiles(const std::map<TileKey, TileRecord>& records, int top_level, const ViewCamera& camera,
                           double max_error_px) {
  Traversal t{records, camera, max_error_px, {}};
  for (const auto& [key, r] : records)
    if (key.level == top_level) t.visit(r);
  return std::move(t.out);
}

TileSelection select_tiles_to_fit(const std::map<TileKey, TileRecord>& records, int top_level, const ViewCamera& camera,
                                  double max_error_px, size_t fit_bytes, double limit_px, double* used_px) {
  *used_px = max_error_px;
  TileSelection s = select_tiles(records, top_level, camera, *used_px);
  while (fit_bytes > 0 && s.render_bytes > fit_bytes && *used_px < limit_px) {
    *used_px = std::min(limit_px, std::max(1.0, 2.0 * *used_px));
    s = select_tiles(records, top_level, camera, *used_px);
  }
  return s;
}

}  // namespace rgbdcast::tiles
