#include <meshoptimizer.h>

#include "reduction/stages.h"

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
  // Keep only the vertices still referenced, with their colours.
  std::vector<std::int64_t> remap(mesh.positions.size(), -1);
  Mesh simplified;
  simplified.indices.reserve(n);
  for (std::uint32_t i : out) {
    if (remap[i] < 0) {
      remap[i] = static_cast<std::int64_t>(simplified.positions.size());
      simplified.positions.push_back(mesh.positions[i]);
      if (!mesh.colors.empty()) simplified.colors.push_back(mesh.colors[i]);
    }
    simplified.indices.push_back(static_cast<std::uint32_t>(remap[i]));
  }
  mesh = std::move(simplified);
}

}  // namespace rgbdcast
