#include "tiles/tile_selection.h"

#include <array>
#include <cmath>
#include <queue>

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

// A tile's screen-space error in pixels (tile_selection.h); infinite for a camera inside its box.
double screen_error_px(const TileRecord& r, const ViewCamera& camera) {
  const double d = distance_to_box(r.box, camera);
  return d > 0.0 ? r.geometric_error_m * camera.fy / d : INFINITY;
}

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
      if (screen_error_px(r, camera) <= max_error_px) return draw(r);
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

namespace {

// Refinement in order of screen-space error under a byte budget (tile_selection.h, select_tiles_within).
class BudgetTraversal {
 public:
  BudgetTraversal(const std::map<TileKey, TileRecord>& records, const ViewCamera& camera, double max_error_px,
                  size_t fit_bytes)
      : records_(records), camera_(camera), max_error_px_(max_error_px), fit_bytes_(fit_bytes) {}

  TileSelection run(int top_level) {
    for (const auto& [key, r] : records_) {
      if (key.level != top_level) continue;
      ++out_.visited;
      if (box_in_frustum(r.box, camera_))
        add(r);
      else
        ++out_.culled;
    }
    while (!queue_.empty()) {
      const Candidate c = queue_.top();
      queue_.pop();
      refine_if_it_fits(*c.record);
    }
    for (const auto& [key, r] : drawn_) {
      out_.tiles.push_back(r);
      out_.triangles += r->triangles;
      out_.bytes += r->bytes;
    }
    out_.render_bytes = render_bytes_;
    return std::move(out_);
  }

 private:
  struct Candidate {
    double sse_px;
    const TileRecord* record;
    // The largest error first; among equal ones (a camera inside several boxes: infinite) the coarser tile, then the
    // key, so that the order does not depend on the heap.
    bool operator<(const Candidate& o) const {
      if (sse_px != o.sse_px) return sse_px < o.sse_px;
      if (record->key.level != o.record->key.level) return record->key.level < o.record->key.level;
      return o.record->key < record->key;
    }
  };

  // The visible children of r (culled ones counted).
  std::vector<const TileRecord*> visible_children(const TileRecord& r) {
    std::vector<const TileRecord*> out;
    for (const TileRecord* c : children_of(records_, r.key)) {
      ++out_.visited;
      if (box_in_frustum(c->box, camera_))
        out.push_back(c);
      else
        ++out_.culled;
    }
    return out;
  }

  // A visible tile joins the drawn set; a stale one is replaced by its visible children at once (it cannot be drawn).
  void add(const TileRecord& r) {
    if (r.key.level > 0 && r.stale) {
      for (const TileRecord* c : visible_children(r)) add(*c);
      return;
    }
    drawn_.emplace(r.key, &r);
    render_bytes_ += r.render_bytes;
    if (r.key.level == 0 || children_of(records_, r.key).empty()) return;
    const double sse_px = screen_error_px(r, camera_);
    if (sse_px > max_error_px_) queue_.push({sse_px, &r});
  }

  // REPLACE: r gives way to all its visible children, or it stays.
  void refine_if_it_fits(const TileRecord& r) {
    const std::vector<const TileRecord*> children = visible_children(r);
    std::uint64_t children_bytes = 0;
    for (const TileRecord* c : children) children_bytes += c->render_bytes;
    if (render_bytes_ - r.render_bytes + children_bytes > fit_bytes_) return;
    drawn_.erase(r.key);
    render_bytes_ -= r.render_bytes;
    for (const TileRecord* c : children) add(*c);
  }

  const std::map<TileKey, TileRecord>& records_;
  const ViewCamera& camera_;
  const double max_error_px_;
  const size_t fit_bytes_;
  std::priority_queue<Candidate> queue_;
  std::map<TileKey, const TileRecord*> drawn_;  // by key: the draw order does not depend on addresses
  std::uint64_t render_bytes_ = 0;
  TileSelection out_;
};

}  // namespace

TileSelection select_tiles_within(const std::map<TileKey, TileRecord>& records, int top_level, const ViewCamera& camera,
                                  double max_error_px, size_t fit_bytes) {
  return BudgetTraversal(records, camera, max_error_px, fit_bytes).run(top_level);
}

TileSelection select_tiles_to_fit(const std::map<TileKey, TileRecord>& records, int top_level, const ViewCamera& camera,
                                  double max_error_px, size_t fit_bytes, double limit_px, double* used_px) {
  *used_px = max_error_px;
  TileSelection s = select_tiles(records, top_level, camera, *used_px);
  while (fit_bytes > 0 && s.render_bytes > fit_bytes && *used_px < limit_px) {
    *used_px = std::min(limit_px, std::max(1.0, 2.0 * *used_px));
    s = select_tiles(records, top_level, camera, *used_px);
  }
  // No uniform error fits: a camera inside tiles' boxes refines them at any error.
  if (fit_bytes > 0 && s.render_bytes > fit_bytes)
    s = select_tiles_within(records, top_level, camera, max_error_px, fit_bytes);
  return s;
}

}  // namespace rgbdcast::tiles
