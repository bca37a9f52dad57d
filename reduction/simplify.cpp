#include <meshoptimizer.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

#include "reduction/mesh_edges.h"
#include "reduction/stages.h"
#include "scene/mesh_compact.h"

namespace rgbdcast {

// Edge collapses (meshoptimizer's quadric simplifier) until the next one would move the surface by more than
// max_error_m. Borders are locked, so the mesh's outline and its holes stay where the depth put them; only the
// interior of smooth surfaces, which a 1 cm voxel grid tessellates far more finely than it needs, loses triangles.
// The texture is applied afterwards, so the colour detail does not depend on the triangle count.
void simplify_mesh(Mesh& mesh, double max_error_m) {
  if (max_error_m <= 0 || mesh.indices.size() < 3) return;
  const float* positions = mesh.positions.front().data();
  const size_t stride = sizeof(Eigen::Vector3f);
  const float scale = meshopt_simplifyScale(positions, mesh.positions.size(), stride);
  if (!(scale > 0)) return;
  std::vector<std::uint32_t> out(mesh.indices.size());
  const size_t n = meshopt_simplify(out.data(), mesh.indices.data(), mesh.indices.size(), positions,
                                    mesh.positions.size(), stride, /*target_index_count=*/0,
                                    static_cast<float>(max_error_m / scale), meshopt_SimplifyLockBorder, nullptr);
  out.resize(n);
  mesh = compact_mesh(std::move(mesh), out);
}

// The realtime mesh's edge collapses, in the space its error model lives in: (u, v) in pixels and inverse depth in
// units of `w_unit` (the sensor's inverse-depth sigma times the tolerance), so one unit of quadric error is one pixel
// across the image or one tolerance in depth. Borders are not locked: a staircase of one-pixel steps along a depth
// discontinuity or a hole collapses into a few long edges that stay within max_error of it.
size_t simplify_image_space(Mesh& mesh, const Intrinsics& k, double w_unit, double max_error, double texture_limit_px,
                            const std::vector<std::uint32_t>* edge_uses) {
  if (mesh.indices.size() < 3 || !(w_unit > 0)) return mesh.triangle_count();
  std::vector<float> uvw(3 * mesh.positions.size());
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const Eigen::Vector3f& p = mesh.positions[i];
    uvw[3 * i] = static_cast<float>(k.fx * p.x() / p.z() + k.cx);
    uvw[3 * i + 1] = static_cast<float>(k.fy * p.y() / p.z() + k.cy);
    uvw[3 * i + 2] = static_cast<float>(1.0 / (p.z() * w_unit));
  }
  // Affine texturing over a triangle of L pixels on a surface whose depth changes by a fraction g a pixel deviates
  // about L^2 g / 4 pixels from the projective mapping. Collapses grow triangles without bound where the surface is
  // flat, so a vertex may only move where that stays within `texture_limit_px` for triangles of kMaxFreeLegPx, or on
  // the outline (the staircases the collapses are for): every other vertex is lifted off its surface by alternating
  // offsets far above the error, so no collapse can involve it. The slope is read on edges of at least
  // kMinSlopeEdgePx (the hierarchy's large triangles are where flat oblique surfaces are).
  constexpr double kMaxFreeLegPx = 48, kMinSlopeEdgePx = 8;
  const double g_max = texture_limit_px > 0 ? 4 * texture_limit_px / (kMaxFreeLegPx * kMaxFreeLegPx) : 1e30;
  std::vector<float> g(mesh.positions.size(), 0.f);
  auto key = [](std::uint32_t a, std::uint32_t b) { return std::uint64_t(std::min(a, b)) << 32 | std::max(a, b); };
  std::vector<std::uint32_t> counted;
  if (!edge_uses || edge_uses->size() != mesh.indices.size())
    counted = edge_use_counts(mesh.indices, mesh.positions.size());
  const std::vector<std::uint32_t>& uses = counted.empty() ? *edge_uses : counted;
  for (size_t t = 0; t < mesh.indices.size(); t += 3)
    for (int e = 0; e < 3; ++e) {
      const std::uint32_t a = mesh.indices[t + e], b = mesh.indices[t + (e + 1) % 3];
      // (The float hypot as glibc's hypotf computes it, after a test on the square that skips the short edges,
      // most of them, without a square root.)
      const double du = uvw[3 * a] - uvw[3 * b], dv = uvw[3 * a + 1] - uvw[3 * b + 1], squared = du * du + dv * dv;
      if (squared < 0.99 * kMinSlopeEdgePx * kMinSlopeEdgePx) continue;
      const double len = static_cast<float>(std::sqrt(squared));
      if (len < kMinSlopeEdgePx) continue;  // a short edge's depth difference is mostly the sensor's noise
      const double za = mesh.positions[a].z(), zb = mesh.positions[b].z();
      const float ga = static_cast<float>(std::abs(za - zb) / (0.5 * (za + zb)) / std::max(1.0, len));
      g[a] = std::max(g[a], ga), g[b] = std::max(g[b], ga);
    }
  std::vector<std::uint8_t> free_vertex(mesh.positions.size(), 0);
  for (size_t i = 0; i < g.size(); ++i) free_vertex[i] = g[i] <= g_max;
  for (size_t s = 0; s < uses.size(); ++s)  // an edge of one triangle is on the outline: both its ends may move
    if (uses[s] == 1) free_vertex[mesh.indices[s]] = free_vertex[mesh.indices[s - s % 3 + (s % 3 + 1) % 3]] = 1;
  const float lift = static_cast<float>(100 * std::max(1.0, max_error));
  for (size_t i = 0; i < mesh.positions.size(); ++i)
    if (!free_vertex[i]) uvw[3 * i + 2] += (i % 2 ? lift : -lift);
  const float scale = meshopt_simplifyScale(uvw.data(), mesh.positions.size(), 3 * sizeof(float));
  if (!(scale > 0)) return mesh.triangle_count();
  std::vector<std::uint32_t> out(mesh.indices.size());
  const size_t n =
      meshopt_simplify(out.data(), mesh.indices.data(), mesh.indices.size(), uvw.data(), mesh.positions.size(),
                       3 * sizeof(float), /*target_index_count=*/0, static_cast<float>(max_error / scale), 0, nullptr);
  out.resize(n);
  // meshoptimizer rejects collapses that flip a triangle in its own space, where the inverse depth axis makes
  // triangles steep; a few still fold over in the image. Those (no longer counter-clockwise seen from the camera,
  // as extract() emits every triangle) are dropped: folds sit over their neighbours, so little is uncovered.
  size_t kept = 0;
  for (size_t t = 0; t < out.size(); t += 3) {
    const float* a = &uvw[3 * out[t]];
    const float* b = &uvw[3 * out[t + 1]];
    const float* c = &uvw[3 * out[t + 2]];
    const double area = double(b[0] - a[0]) * (c[1] - a[1]) - double(b[1] - a[1]) * (c[0] - a[0]);
    if (area < -1e-3) {  // (a sliver of no area is dropped too)
      std::copy(out.begin() + t, out.begin() + t + 3, out.begin() + kept);
      kept += 3;
    }
  }
  out.resize(kept);
  // A fold can also leave an edge with three triangles: the smallest of them go until two remain.
  const std::vector<std::uint32_t> out_uses = edge_use_counts(out, mesh.positions.size());
  std::vector<std::pair<std::uint64_t, size_t>> by_edge;  // (edge, triangle) of those edges, sorted by edge
  for (size_t s = 0; s < out_uses.size(); ++s)
    if (out_uses[s] > 2) by_edge.push_back({key(out[s], out[s - s % 3 + (s % 3 + 1) % 3]), s - s % 3});
  std::sort(by_edge.begin(), by_edge.end());
  std::vector<bool> drop(out.size() / 3, false);
  auto image_area = [&](size_t t) {
    const float *a = &uvw[3 * out[t]], *b = &uvw[3 * out[t + 1]], *c = &uvw[3 * out[t + 2]];
    return std::abs(double(b[0] - a[0]) * (c[1] - a[1]) - double(b[1] - a[1]) * (c[0] - a[0]));
  };
  std::vector<size_t> ts;
  for (size_t i = 0; i < by_edge.size();) {
    size_t j = i + 1;
    while (j < by_edge.size() && by_edge[j].first == by_edge[i].first) ++j;
    if (j - i > 2) {
      ts.clear();
      for (size_t k2 = i; k2 < j; ++k2) ts.push_back(by_edge[k2].second);
      std::sort(ts.begin(), ts.end(), [&](size_t x, size_t y) { return image_area(x) > image_area(y); });
      for (size_t k2 = 2; k2 < ts.size(); ++k2) drop[ts[k2] / 3] = true;
    }
    i = j;
  }
  kept = 0;
  for (size_t t = 0; t < out.size(); t += 3)
    if (!drop[t / 3]) {
      std::copy(out.begin() + t, out.begin() + t + 3, out.begin() + kept);
      kept += 3;
    }
  out.resize(kept);
  mesh = compact_mesh(std::move(mesh), out);
  return mesh.triangle_count();
}

}  // namespace rgbdcast
