// An inner tile's content: its children's surfaces welded, simplified (meshoptimizer), coloured per vertex.
#include <meshoptimizer.h>

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "atlas/cell_fill.h"
#include "tiles/tile_content.h"

namespace rgbdcast::tiles {
namespace {

constexpr double kWeldStepM = 0.001;  // children's GLBs are quantized to 1 mm; their shared corners meet on this grid

struct GridKey {
  std::int64_t x, y, z;
  bool operator==(const GridKey&) const = default;
};
struct GridHash {
  size_t operator()(const GridKey& k) const {
    return static_cast<size_t>(k.x * 73856093LL ^ k.y * 19349663LL ^ k.z * 83492791LL);
  }
};

// The welded surface being gathered: one vertex per 1 mm grid point, its colour the mean of its corners'.
struct Welded {
  std::vector<Eigen::Vector3f> positions;
  std::vector<std::array<std::uint32_t, 4>> color_sums;  // r, g, b, count
  std::vector<std::uint32_t> indices;
  std::unordered_map<GridKey, std::uint32_t, GridHash> index_of;

  std::uint32_t vertex(const Eigen::Vector3f& p, const std::uint8_t* rgb) {
    const GridKey key{std::llround(p.x() / kWeldStepM), std::llround(p.y() / kWeldStepM),
                      std::llround(p.z() / kWeldStepM)};
    auto [it, added] = index_of.emplace(key, static_cast<std::uint32_t>(positions.size()));
    if (added) {
      positions.push_back(p);
      color_sums.push_back({0, 0, 0, 0});
    }
    auto& c = color_sums[it->second];
    c[0] += rgb[0], c[1] += rgb[1], c[2] += rgb[2], c[3] += 1;
    return it->second;
  }
};

// The colour of a child's vertex: its texture at its uv, else its colour, else grey.
void corner_color(const Mesh& m, const CellSource* texture, std::uint32_t v, std::uint8_t* rgb) {
  if (texture) {
    const Eigen::Vector2f& uv = m.uvs[v];
    sample_bilinear_rgb(*texture, uv.x() * texture->cols - 0.5, uv.y() * texture->rows - 0.5, rgb);
  } else if (!m.colors.empty()) {
    std::copy(m.colors[v].begin(), m.colors[v].end(), rgb);
  } else {
    rgb[0] = rgb[1] = rgb[2] = 128;
  }
}

Status gather(const Mesh& m, Welded* w) {
  if (m.indices.size() % 3 != 0 || (!m.uvs.empty() && m.uvs.size() != m.positions.size()) ||
      (!m.colors.empty() && m.colors.size() != m.positions.size()))
    return make_error(ErrorCode::kInvalidInput, "inner tile: a child mesh is inconsistent");
  const bool textured = !m.uvs.empty() && !m.texture.empty() && m.texture.channels == 3;
  const CellSource texture = textured ? cell_source(m.texture) : CellSource{};
  for (size_t t = 0; t + 2 < m.indices.size(); t += 3) {
    std::array<std::uint32_t, 3> tri;
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = m.indices[t + k];
      if (v >= m.positions.size()) return make_error(ErrorCode::kInvalidInput, "inner tile: index out of range");
      std::uint8_t rgb[3];
      corner_color(m, textured ? &texture : nullptr, v, rgb);
      tri[k] = w->vertex(m.positions[v], rgb);
    }
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) continue;  // collapsed by the weld
    w->indices.insert(w->indices.end(), tri.begin(), tri.end());
  }
  return ok_status();
}

}  // namespace

Result<InnerTile> build_inner(const std::vector<const Mesh*>& children, size_t target_triangles, bool lock_border) {
  Welded w;
  for (const Mesh* m : children)
    if (auto st = gather(*m, &w); !st) return st.error();
  if (w.indices.empty()) return make_error(ErrorCode::kEmpty, "inner tile: the children hold no triangle");
  InnerTile out;
  out.merged_triangles = w.indices.size() / 3;
  // A level up halves the detail along each floor axis: a quarter of the triangles, at most target_triangles.
  const size_t target = std::max<size_t>(1, std::min(target_triangles, (out.merged_triangles + 3) / 4));
  std::vector<std::uint32_t> simplified(w.indices.size());
  float relative_error = 0.0f;
  const size_t kept = meshopt_simplify(simplified.data(), w.indices.data(), w.indices.size(),
                                       &w.positions[0].x(), w.positions.size(), sizeof(Eigen::Vector3f), 3 * target,
                                       1.0f, lock_border ? unsigned(meshopt_SimplifyLockBorder) : 0u, &relative_error);
  simplified.resize(kept);
  const float scale = meshopt_simplifyScale(&w.positions[0].x(), w.positions.size(), sizeof(Eigen::Vector3f));
  out.simplify_error_m = static_cast<double>(relative_error) * scale;
  if (simplified.empty()) return make_error(ErrorCode::kEmpty, "inner tile: nothing left after simplification");
  // Keep the vertices the simplified triangles use, in the order they are first used.
  std::vector<std::uint32_t> remap(w.positions.size(), UINT32_MAX);
  for (std::uint32_t& v : simplified) {
    if (remap[v] == UINT32_MAX) {
      remap[v] = static_cast<std::uint32_t>(out.mesh.positions.size());
      out.mesh.positions.push_back(w.positions[v]);
      const auto& c = w.color_sums[v];
      out.mesh.colors.push_back({static_cast<std::uint8_t>(c[0] / c[3]), static_cast<std::uint8_t>(c[1] / c[3]),
                                 static_cast<std::uint8_t>(c[2] / c[3])});
    }
    v = remap[v];
  }
  out.mesh.indices = std::move(simplified);
  return out;
}

}  // namespace rgbdcast::tiles
