// A leaf's content: one keyframe's surface in world coordinates.
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <optional>

#include "atlas/cell_fill.h"
#include "atlas/footprint_layout.h"
#include "tiles/tile_bake.h"
#include "tiles/tile_content.h"

namespace rgbdcast::tiles {
namespace {

std::array<Eigen::Vector3d, 3> world_triangle(const SceneNode& node, size_t t) {
  std::array<Eigen::Vector3d, 3> v;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d p = node.mesh.positions[node.mesh.indices[3 * t + k]].cast<double>();
    v[k] = (node.to_world * p.homogeneous()).head<3>();
  }
  return v;
}

bool mesh_consistent(const Mesh& m) {
  if (m.indices.size() % 3 != 0) return false;
  if (!m.uvs.empty() && m.uvs.size() != m.positions.size()) return false;
  if (!m.colors.empty() && m.colors.size() != m.positions.size()) return false;
  return std::all_of(m.indices.begin(), m.indices.end(), [&](std::uint32_t i) { return i < m.positions.size(); });
}

// One triangle of the leaf: where it comes from and how its texture cell is laid out.
struct LeafTriangle {
  const SceneNode* node = nullptr;
  std::array<std::uint32_t, 3> corner{};  // source vertex indices, the cell's right-angle corner first
  std::array<Eigen::Vector3d, 3> world;
  int leg = 1;
};

// The affine map from a cell triangle's atlas corners to pixel centres of the source texture.
Eigen::Matrix3d affine_from_corners(const std::array<Eigen::Vector2d, 3>& atlas,
                                    const std::array<Eigen::Vector2d, 3>& image) {
  Eigen::Matrix3d A, B;
  for (int k = 0; k < 3; ++k) {
    A.col(k) << atlas[k], 1.0;
    B.col(k) << image[k], 1.0;
  }
  return B * A.inverse();
}

std::array<Eigen::Vector2d, 3> source_pixels(const LeafTriangle& t) {
  const Mesh& m = t.node->mesh;
  std::array<Eigen::Vector2d, 3> px;
  for (int k = 0; k < 3; ++k)
    px[k] = m.uvs[t.corner[k]].cast<double>().cwiseProduct(Eigen::Vector2d(m.texture.width, m.texture.height)) -
            Eigen::Vector2d(0.5, 0.5);
  return px;
}

Rgb8 mean_color(const LeafTriangle& t) {
  const Mesh& m = t.node->mesh;
  if (m.colors.empty()) return {128, 128, 128};
  int sum[3] = {0, 0, 0};
  for (int k = 0; k < 3; ++k)
    for (int c = 0; c < 3; ++c) sum[c] += m.colors[t.corner[k]][c];
  return {static_cast<std::uint8_t>(sum[0] / 3), static_cast<std::uint8_t>(sum[1] / 3),
          static_cast<std::uint8_t>(sum[2] / 3)};
}

}  // namespace

std::optional<TileKey> keyframe_leaf(const Scene& placed, std::int64_t seq, double leaf_size_m) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  size_t n = 0;
  for (const SceneNode& node : placed.nodes) {
    if (!mesh_consistent(node.mesh)) continue;
    for (size_t t = 0; t < node.mesh.triangle_count(); ++t) {
      const auto v = world_triangle(node, t);
      sum += (v[0] + v[1] + v[2]) / 3.0;
      ++n;
    }
  }
  if (n == 0) return std::nullopt;
  const Eigen::Vector3d c = sum / double(n);
  TileKey key = leaf_key(c.x(), c.z(), leaf_size_m);
  key.keyframe = seq;
  return key;
}

namespace {

// Several meshed nodes (a keyframe GLB may hold more than one): their triangles in one footprint atlas.
Result<Mesh> bake_nodes(const Scene& placed, const std::string& name, const LeafBakeOptions& options) {
  std::vector<LeafTriangle> tris;
  for (const SceneNode& node : placed.nodes) {
    if (!mesh_consistent(node.mesh)) continue;
    for (size_t t = 0; t < node.mesh.triangle_count(); ++t) {
      LeafTriangle lt;
      lt.node = &node;
      const auto world = world_triangle(node, t);
      int right = 0;
      if (node.mesh.textured() && !node.mesh.texture.empty()) {
        std::array<Eigen::Vector2d, 3> px;
        for (int k = 0; k < 3; ++k)
          px[k] = node.mesh.uvs[node.mesh.indices[3 * t + k]].cast<double>().cwiseProduct(
              Eigen::Vector2d(node.mesh.texture.width, node.mesh.texture.height));
        lt.leg = footprint_leg_class(footprint_leg_px(px, &right));
      } else {
        lt.leg = 2;
      }
      for (int k = 0; k < 3; ++k) {
        lt.corner[k] = node.mesh.indices[3 * t + (right + k) % 3];
        lt.world[k] = world[(right + k) % 3];
      }
      tris.push_back(lt);
    }
  }
  if (tris.empty()) return make_error(ErrorCode::kEmpty, "leaf " + name + ": no triangle");
  std::vector<BakeTriangle> cells(tris.size());
  for (size_t i = 0; i < tris.size(); ++i) cells[i] = {tris[i].world, tris[i].leg};
  auto mesh = bake_atlas_mesh(
      cells, options,
      [&](size_t i, const FootprintSlot& slot, const std::array<Eigen::Vector2d, 3>& corners, Image* atlas,
          std::uint8_t* sampled) {
        const LeafTriangle& t = tris[i];
        const Mesh& m = t.node->mesh;
        if (m.textured() && !m.texture.empty() && m.texture.channels == 3) {
          const auto px = source_pixels(t);
          const Eigen::Vector2d centre = (px[0] + px[1] + px[2]) / 3.0;  // an affine map never needs the fallback
          fill_cell_triangle(slot, affine_from_corners(corners, px), Eigen::Vector3d(centre.x(), centre.y(), 1),
                             cell_source(m.texture), atlas, sampled);
        } else {  // a vertex-coloured triangle: one colour, the mean of its corners'
          const Rgb8 rgb = mean_color(t);
          fill_cell_texels(slot, atlas, sampled,
                           [&](double, double, std::uint8_t* px) { std::copy(rgb.begin(), rgb.end(), px); });
        }
      });
  if (!mesh && mesh.error().code != ErrorCode::kEmpty)
    return make_error(mesh.error().code, "leaf " + name + ": " + mesh.error().message);
  return mesh;
}

}  // namespace

Result<SceneNode> build_leaf(const Scene& placed, const std::string& name, const LeafBakeOptions& options) {
  const SceneNode* meshed = nullptr;
  size_t count = 0;
  for (const SceneNode& node : placed.nodes) {
    if (node.mesh.triangle_count() == 0) continue;
    if (!mesh_consistent(node.mesh))
      return make_error(ErrorCode::kInvalidInput, "leaf " + name + ": indices, uvs or colours do not match positions");
    meshed = &node;
    ++count;
  }
  if (count == 0) return make_error(ErrorCode::kEmpty, "leaf " + name + ": no triangle");
  SceneNode leaf;
  leaf.name = "tile_" + name;
  if (count == 1) {  // as it is: the leaf shows exactly what the keyframe GLB shows, its texture not encoded again
    leaf.mesh = meshed->mesh;
    leaf.to_world = meshed->to_world;
    return leaf;
  }
  auto baked = bake_nodes(placed, name, options);
  if (!baked) return baked.error();
  leaf.mesh = std::move(*baked);
  return leaf;
}

Eigen::AlignedBox3d mesh_box(const Mesh& mesh, double pad_m) {
  Eigen::AlignedBox3d box;
  for (const auto& p : mesh.positions) box.extend(p.cast<double>());
  if (!box.isEmpty()) {
    box.min().array() -= pad_m;
    box.max().array() += pad_m;
  }
  return box;
}

}  // namespace rgbdcast::tiles
