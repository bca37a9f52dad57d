#include "tests/atlas/right_triangle_mesh.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace rgbdcast::test {

namespace {

struct Builder {
  int width, height;
  const PointAt& point_at;
  const SplitBlock& split;
  RightTriangleMeshOptions options;
  Mesh mesh;
  std::unordered_map<long long, std::int64_t> vertex_of;  // pixel -> vertex index, -1 when no point

  std::int64_t vertex(int x, int y) {
    const long long key = static_cast<long long>(y) * width + x;
    auto it = vertex_of.find(key);
    if (it != vertex_of.end()) return it->second;
    Eigen::Vector3f p;
    std::int64_t id = -1;
    if (point_at(x, y, &p) && p.allFinite() && p.z() > 0) {
      id = static_cast<std::int64_t>(mesh.positions.size());
      mesh.positions.push_back(p);
    }
    vertex_of.emplace(key, id);
    return id;
  }

  void triangle(int ax, int ay, int bx, int by, int cx, int cy) {
    const std::int64_t a = vertex(ax, ay), b = vertex(bx, by), c = vertex(cx, cy);
    if (a < 0 || b < 0 || c < 0) return;
    const float za = mesh.positions[a].z(), zb = mesh.positions[b].z(), zc = mesh.positions[c].z();
    if (std::max({za, zb, zc}) > options.max_depth_ratio * std::min({za, zb, zc})) return;
    mesh.indices.insert(mesh.indices.end(),
                        {static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(b), static_cast<std::uint32_t>(c)});
  }

  void block(int x, int y, int s) {
    const bool inside = x + s <= width - 1 && y + s <= height - 1;
    if (s > options.min_side_px && (!inside || split(x, y, s))) {
      const int h = s / 2;
      block(x, y, h), block(x + h, y, h), block(x, y + h, h), block(x + h, y + h, h);
      return;
    }
    if (!inside) return;
    if (s >= options.min_diagonal_side_px &&
        ((x / s + y / s) & 1) == 1) {  // four triangles around the centre: diagonal legs
      const int cx = x + s / 2, cy = y + s / 2;
      triangle(cx, cy, x, y, x + s, y);
      triangle(cx, cy, x + s, y, x + s, y + s);
      triangle(cx, cy, x + s, y + s, x, y + s);
      triangle(cx, cy, x, y + s, x, y);
    } else {  // two along the diagonal: axis-aligned legs
      triangle(x, y, x + s, y, x, y + s);
      triangle(x + s, y, x + s, y + s, x, y + s);
    }
  }
};

}  // namespace

Mesh right_triangle_mesh(int width, int height, const PointAt& point_at, const SplitBlock& split,
                         const RightTriangleMeshOptions& options) {
  Builder b{width, height, point_at, split, options, {}, {}};
  const int S = options.max_side_px;
  for (int y = 0; y < height - 1; y += S)
    for (int x = 0; x < width - 1; x += S) b.block(x, y, S);
  return std::move(b.mesh);
}

Mesh right_triangle_mesh_of_depth(const cv::Mat& depth_m, const Intrinsics& k, double tolerance_factor,
                                  const RightTriangleMeshOptions& options) {
  auto z = [&](int x, int y) { return depth_m.at<float>(y, x); };
  const PointAt point_at = [&](int x, int y, Eigen::Vector3f* p) {
    const float d = z(x, y);
    if (!(d > 0)) return false;
    *p = Eigen::Vector3f(static_cast<float>((x - k.cx) / k.fx * d), static_cast<float>((y - k.cy) / k.fy * d), d);
    return true;
  };
  const SplitBlock split = [&](int x, int y, int s) {
    const float z00 = z(x, y), z10 = z(x + s, y), z01 = z(x, y + s), z11 = z(x + s, y + s);
    if (!(z00 > 0 && z10 > 0 && z01 > 0 && z11 > 0)) return true;
    if (std::max({z00, z10, z01, z11}) > options.max_depth_ratio * std::min({z00, z10, z01, z11})) return true;
    for (int j = 0; j <= s; ++j)
      for (int i = 0; i <= s; ++i) {
        const float d = z(x + i, y + j);
        if (!(d > 0)) return true;
        const float a = float(i) / s, b = float(j) / s;
        const float fit = (1 - b) * ((1 - a) * z00 + a * z10) + b * ((1 - a) * z01 + a * z11);
        if (std::abs(d - fit) > tolerance_factor * 1.425e-3f * d * d) return true;
      }
    return false;
  };
  return right_triangle_mesh(depth_m.cols, depth_m.rows, point_at, split, options);
}

}  // namespace rgbdcast::test
