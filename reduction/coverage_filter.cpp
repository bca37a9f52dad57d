#include "reduction/coverage_filter.h"

#include <Eigen/Geometry>
#include <cmath>

#include "scene/mesh_compact.h"

namespace rgbdcast {

namespace {

bool seen_by(const Eigen::Vector3d& world, const CoverageView& view, const Eigen::Matrix4d& world_to_camera,
             const CoverageParams& p) {
  const Eigen::Vector3d c = (world_to_camera * world.homogeneous()).head<3>();
  if (c.z() <= 0.05) return false;
  const Eigen::Vector2d px = view.intrinsics.project(c);
  const int u = static_cast<int>(std::lround(px.x())), v = static_cast<int>(std::lround(px.y()));
  if (u < p.border_px || v < p.border_px || u >= view.depth_m.cols - p.border_px ||
      v >= view.depth_m.rows - p.border_px)
    return false;
  const float d = view.depth_m.at<float>(v, u);
  if (!(d > 0)) return false;
  const double sigma = 1.425e-3 * c.z() * c.z();  // Kinect depth noise (Khoshelham & Elberink 2012)
  return std::abs(d - c.z()) <= p.depth_tolerance_m + 3 * sigma;
}

}  // namespace

size_t drop_covered_triangles(Mesh& mesh, const Eigen::Matrix4d& mesh_to_world,
                              const std::vector<CoverageView>& earlier, const CoverageParams& params) {
  if (earlier.empty() || mesh.indices.empty()) return 0;
  std::vector<Eigen::Matrix4d> world_to_camera;
  for (const auto& v : earlier) world_to_camera.push_back(v.camera_to_world.inverse());
  std::vector<Eigen::Vector3d> world(mesh.positions.size());
  for (size_t i = 0; i < world.size(); ++i)
    world[i] = (mesh_to_world * mesh.positions[i].cast<double>().homogeneous()).head<3>();
  // Per view, which vertices it sees (computed once per vertex, not per triangle corner).
  std::vector<std::vector<bool>> seen(earlier.size(), std::vector<bool>(world.size()));
  for (size_t k = 0; k < earlier.size(); ++k)
    for (size_t i = 0; i < world.size(); ++i) seen[k][i] = seen_by(world[i], earlier[k], world_to_camera[k], params);

  std::vector<std::uint32_t> kept;
  kept.reserve(mesh.indices.size());
  size_t removed = 0;
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const std::uint32_t a = mesh.indices[t], b = mesh.indices[t + 1], c = mesh.indices[t + 2];
    bool covered = false;
    for (size_t k = 0; k < earlier.size() && !covered; ++k) covered = seen[k][a] && seen[k][b] && seen[k][c];
    if (covered)
      ++removed;
    else
      kept.insert(kept.end(), {a, b, c});
  }
  if (removed == 0) return 0;
  mesh = compact_mesh(std::move(mesh), kept);
  return removed;
}

}  // namespace rgbdcast
