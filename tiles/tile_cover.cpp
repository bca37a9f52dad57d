#include "tiles/tile_cover.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "scene/mesh_compact.h"

namespace rgbdcast::tiles {
namespace {

constexpr double kNearM = 0.05;
// Where the reduced surface lies over itself (a pixel rasterised more than once) with its nearest and farthest layer
// at most this far apart, it is one fold: a mesh reduced from one depth image has no two surfaces that close behind
// one another (a depth edge is a gap, not a second layer).
constexpr double kFoldM = 0.25;

// Kinect depth noise at range z (Khoshelham & Elberink 2012), as the reduction's coverage filter uses it.
double depth_sigma_m(double z) { return 1.425e-3 * z * z; }

// What build_leaf accepts; a node that is not is left out of coverage (and its leaf refused).
bool consistent(const Mesh& m) {
  if (m.indices.size() % 3 != 0) return false;
  if (!m.uvs.empty() && m.uvs.size() != m.positions.size()) return false;
  if (!m.colors.empty() && m.colors.size() != m.positions.size()) return false;
  return std::all_of(m.indices.begin(), m.indices.end(), [&](std::uint32_t i) { return i < m.positions.size(); });
}

Eigen::Vector3d world_point(const SceneNode& node, std::uint32_t i) {
  return (node.to_world * node.mesh.positions[i].cast<double>().homogeneous()).head<3>();
}

// One triangle (camera coordinates, z > near) into the depth buffers, the nearest surface and the farthest, the depth
// interpolated perspective-correctly (1/z is linear in the image).
void rasterize(CoverDepth& d, const std::array<Eigen::Vector3d, 3>& c) {
  std::array<Eigen::Vector2d, 3> p;
  for (int k = 0; k < 3; ++k) p[k] = {d.fx * c[k].x() / c[k].z() + d.cx, d.fy * c[k].y() / c[k].z() + d.cy};
  auto put = [&d](long x, long y, double z) {
    const size_t i = static_cast<size_t>(y) * d.width + x;
    if (d.depth_m[i] == 0.0f || z < d.depth_m[i]) d.depth_m[i] = static_cast<float>(z);
    d.far_m[i] = std::max(d.far_m[i], static_cast<float>(z));
  };
  // The corners first, in their nearest pixels: a sliver between pixel centres (a steep triangle at a fold) still
  // holds its corners' ranges.
  for (int k = 0; k < 3; ++k) {
    const long x = std::lround(p[k].x()), y = std::lround(p[k].y());
    if (x >= 0 && y >= 0 && x < d.width && y < d.height) put(x, y, c[k].z());
  }
  const double area = (p[1] - p[0]).x() * (p[2] - p[0]).y() - (p[1] - p[0]).y() * (p[2] - p[0]).x();
  if (!(std::abs(area) > 1e-12)) return;
  const int x0 = std::max(0, static_cast<int>(std::ceil(std::min({p[0].x(), p[1].x(), p[2].x()}))));
  const int x1 = std::min(d.width - 1, static_cast<int>(std::floor(std::max({p[0].x(), p[1].x(), p[2].x()}))));
  const int y0 = std::max(0, static_cast<int>(std::ceil(std::min({p[0].y(), p[1].y(), p[2].y()}))));
  const int y1 = std::min(d.height - 1, static_cast<int>(std::floor(std::max({p[0].y(), p[1].y(), p[2].y()}))));
  auto edge = [](const Eigen::Vector2d& a, const Eigen::Vector2d& b, double x, double y) {
    return (b.x() - a.x()) * (y - a.y()) - (b.y() - a.y()) * (x - a.x());
  };
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const double b0 = edge(p[1], p[2], x, y) / area, b1 = edge(p[2], p[0], x, y) / area,
                   b2 = edge(p[0], p[1], x, y) / area;
      if (b0 < -1e-9 || b1 < -1e-9 || b2 < -1e-9) continue;
      put(x, y, 1.0 / (b0 / c[0].z() + b1 / c[1].z() + b2 / c[2].z()));
    }
}

// Whether the depth has a surface at range z within tolerance at pixel (u, v) or one of its 8 neighbours: a corner
// on the outline of an identical surface, or where the surface slopes steeply between two pixel centres, lands within
// a pixel of where the depth holds it.
bool on_surface(const CoverDepth& d, double u, double v, double z, double tolerance) {
  const long cu = std::lround(u), cv = std::lround(v);
  for (long y = cv - 1; y <= cv + 1; ++y)
    for (long x = cu - 1; x <= cu + 1; ++x) {
      if (x < 0 || y < 0 || x >= d.width || y >= d.height) continue;
      const size_t i = static_cast<size_t>(y) * d.width + x;
      if (!(d.depth_m[i] > 0.0f)) continue;
      // Within a fold (layers no farther apart than kFoldM) any range between its layers is on it.
      const bool fold = d.far_m[i] - d.depth_m[i] <= kFoldM;
      if (fold ? (z >= d.depth_m[i] - tolerance && z <= d.far_m[i] + tolerance)
               : (std::abs(d.depth_m[i] - z) <= tolerance || std::abs(d.far_m[i] - z) <= tolerance))
        return true;
    }
  return false;
}

}  // namespace

Eigen::AlignedBox3d cover_box(const Scene& placed, const CoverOptions& options) {
  Eigen::AlignedBox3d box;
  for (const SceneNode& node : placed.nodes)
    if (consistent(node.mesh))
      for (std::uint32_t i : node.mesh.indices) box.extend(world_point(node, i));
  if (box.isEmpty() || placed.cameras.empty()) return box;
  double far = 0.0;
  const Eigen::Vector3d eye = placed.cameras.front().camera_to_world.block<3, 1>(0, 3);
  for (int c = 0; c < 8; ++c)
    far = std::max(far, (box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(c)) - eye).norm());
  const double pad = options.depth_tolerance_m + 3 * depth_sigma_m(far);
  box.min().array() -= pad;
  box.max().array() += pad;
  return box;
}

std::optional<CoverDepth> cover_depth(const Scene& placed, const CoverOptions& options) {
  if (placed.cameras.empty() || options.downscale < 1) return std::nullopt;
  const Intrinsics& in = placed.cameras.front().intrinsics;
  CoverDepth d;
  const double s = options.downscale;
  d.fx = in.fx / s;
  d.fy = in.fy / s;
  d.cx = (in.cx + 0.5) / s - 0.5;
  d.cy = (in.cy + 0.5) / s - 0.5;
  d.width = std::max(1, in.width / options.downscale);
  d.height = std::max(1, in.height / options.downscale);
  d.world_to_camera = placed.cameras.front().camera_to_world.inverse();
  d.depth_m.assign(static_cast<size_t>(d.width) * d.height, 0.0f);
  d.far_m = d.depth_m;
  bool any = false;
  for (const SceneNode& node : placed.nodes) {
    if (!consistent(node.mesh)) continue;
    const Eigen::Matrix4d to_camera = d.world_to_camera * node.to_world;
    for (size_t t = 0; t + 2 < node.mesh.indices.size(); t += 3) {
      std::array<Eigen::Vector3d, 3> c;
      bool front = true;
      for (int k = 0; k < 3; ++k) {
        c[k] = (to_camera * node.mesh.positions[node.mesh.indices[t + k]].cast<double>().homogeneous()).head<3>();
        front = front && c[k].z() > kNearM;
      }
      if (!front) continue;
      rasterize(d, c);
      any = true;
    }
  }
  if (!any) return std::nullopt;
  d.box = cover_box(placed, options);
  return d;
}

size_t mark_covered(const Scene& placed, const CoverDepth& newer, const CoverOptions& options,
                    std::vector<bool>& covered) {
  size_t total = 0;
  for (const SceneNode& node : placed.nodes) total += consistent(node.mesh) ? node.mesh.triangle_count() : 0;
  if (covered.empty()) covered.assign(total, false);
  if (covered.size() != total) return 0;
  const bool own = !placed.cameras.empty();
  const Eigen::Matrix4d own_to_camera =
      own ? Eigen::Matrix4d(placed.cameras.front().camera_to_world.inverse()) : Eigen::Matrix4d::Identity();
  size_t marked = 0, base = 0;
  for (const SceneNode& node : placed.nodes) {
    if (!consistent(node.mesh)) continue;
    std::vector<std::int8_t> seen(node.mesh.positions.size(), -1);  // per vertex: -1 not yet tested, 0 no, 1 yes
    auto seen_by_newer = [&](std::uint32_t i) {
      if (seen[i] >= 0) return seen[i] == 1;
      const Eigen::Vector3d w = world_point(node, i);
      const Eigen::Vector3d c = (newer.world_to_camera * w.homogeneous()).head<3>();
      bool yes = false;
      if (c.z() > kNearM && newer.box.contains(w)) {
        const double range_own = own ? (own_to_camera * w.homogeneous()).z() : c.z();
        if (c.z() <= options.max_range_ratio * std::max(range_own, kNearM))
          yes = on_surface(newer, newer.fx * c.x() / c.z() + newer.cx, newer.fy * c.y() / c.z() + newer.cy, c.z(),
                           options.depth_tolerance_m + 3 * depth_sigma_m(c.z()));
      }
      seen[i] = yes ? 1 : 0;
      return yes;
    };
    for (size_t t = 0; t < node.mesh.triangle_count(); ++t) {
      const size_t g = base + t;
      if (covered[g]) continue;
      const std::uint32_t* tri = &node.mesh.indices[3 * t];
      if (seen_by_newer(tri[0]) && seen_by_newer(tri[1]) && seen_by_newer(tri[2])) {
        covered[g] = true;
        ++marked;
      }
    }
    base += node.mesh.triangle_count();
  }
  return marked;
}

Scene without_covered(const Scene& placed, const std::vector<bool>& covered) {
  Scene out = placed;
  size_t base = 0;
  for (SceneNode& node : out.nodes) {
    if (!consistent(node.mesh)) continue;
    const size_t n = node.mesh.triangle_count();
    std::vector<std::uint32_t> kept;
    kept.reserve(node.mesh.indices.size());
    for (size_t t = 0; t < n; ++t)
      if (base + t >= covered.size() || !covered[base + t])
        kept.insert(kept.end(), node.mesh.indices.begin() + 3 * t, node.mesh.indices.begin() + 3 * t + 3);
    base += n;
    node.mesh = compact_mesh(std::move(node.mesh), kept);
  }
  return out;
}

}  // namespace rgbdcast::tiles
