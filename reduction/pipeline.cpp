#include "reduction/pipeline.h"

#include <pcl/console/print.h>

#include <chrono>
#include <cmath>

#include "reduction/stages.h"

namespace rgbdcast {

Status ReductionParams::validate() const {
  auto positive = [](double v) { return std::isfinite(v) && v > 0; };
  if (outlier_k < 1 || outlier_k > 1000) return make_error(ErrorCode::kInvalidArgument, "outlier K must be 1..1000");
  if (!positive(outlier_std_mul)) return make_error(ErrorCode::kInvalidArgument, "outlier std-dev multiplier must be > 0");
  if (!positive(voxel_size_m) || voxel_size_m > 10)
    return make_error(ErrorCode::kInvalidArgument, "voxel size must be > 0 and at most 10 m");
  if (!positive(max_edge_m) || max_edge_m > 10)
    return make_error(ErrorCode::kInvalidArgument, "max edge length must be > 0 and at most 10 m");
  if (!positive(mu)) return make_error(ErrorCode::kInvalidArgument, "mu must be > 0");
  if (max_neighbours < 3 || max_neighbours > 1000)
    return make_error(ErrorCode::kInvalidArgument, "max neighbours must be 3..1000");
  if (normal_k < 3 || normal_k > 1000) return make_error(ErrorCode::kInvalidArgument, "normal K must be 3..1000");
  if (!positive(perimeter_factor)) return make_error(ErrorCode::kInvalidArgument, "perimeter factor must be > 0");
  if (!(std::isfinite(simplify_error_m) && simplify_error_m >= 0 && simplify_error_m <= 1))
    return make_error(ErrorCode::kInvalidArgument, "simplify error must be between 0 and 1 m");
  return ok_status();
}

namespace {

class StageTimer {
 public:
  explicit StageTimer(std::vector<StageReport>* out) : out_(out), start_(std::chrono::steady_clock::now()) {}
  void done(const char* name, const char* unit, size_t count) {
    const auto now = std::chrono::steady_clock::now();
    out_->push_back({name, unit, count, std::chrono::duration<double, std::milli>(now - start_).count()});
    start_ = now;
  }

 private:
  std::vector<StageReport>* out_;
  std::chrono::steady_clock::time_point start_;
};

PointCloud to_point_cloud(const Cloud& cloud) {
  PointCloud out;
  out.positions.reserve(cloud.size());
  out.colors.reserve(cloud.size());
  for (const auto& p : cloud) {
    out.positions.emplace_back(p.x, p.y, p.z);
    out.colors.push_back({p.r, p.g, p.b});
  }
  return out;
}

// The mesh keeps only the vertices some triangle uses, renumbered in first-use order.
Mesh to_mesh(const Cloud& cloud, const std::vector<std::uint32_t>& triangles) {
  Mesh mesh;
  std::vector<std::int64_t> remap(cloud.size(), -1);
  mesh.indices.reserve(triangles.size());
  for (std::uint32_t i : triangles) {
    if (remap[i] < 0) {
      remap[i] = static_cast<std::int64_t>(mesh.positions.size());
      const auto& p = cloud[i];
      mesh.positions.emplace_back(p.x, p.y, p.z);
      mesh.colors.push_back({p.r, p.g, p.b});
    }
    mesh.indices.push_back(static_cast<std::uint32_t>(remap[i]));
  }
  return mesh;
}

}  // namespace

Result<ReducedFrame> reduce_frame(const RgbdFrame& frame, const ReductionParams& params) {
  if (auto st = params.validate(); !st) return st.error();
  // PCL prints its own diagnostics (e.g. greedy triangulation's "not enough neighbours"); rgbdcast reports
  // through Result and the stage report instead.
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  if (frame.depth_m.empty() || frame.color_rgb.empty() || frame.depth_m.size() != frame.color_rgb.size())
    return make_error(ErrorCode::kInvalidInput, "frame has no images or colour and depth differ in size");
  ReducedFrame out;
  StageTimer timer(&out.stages);

  std::vector<int> pixel_of_point;
  Cloud::Ptr valid = backproject_valid(frame, &pixel_of_point);
  timer.done("valid", "points", valid->size());
  if (valid->empty()) return make_error(ErrorCode::kEmpty, "no valid depth in the frame");

  const std::vector<int> kept =
      params.outlier_method == OutlierMethod::kOrganized
          ? statistical_outliers_organized(*valid, pixel_of_point, frame.depth_m.cols, frame.depth_m.rows,
                                           params.outlier_k, params.outlier_std_mul)
          : statistical_outliers_kdtree(valid, params.outlier_k, params.outlier_std_mul);
  auto inliers = std::make_shared<Cloud>(*valid, pcl::Indices(kept.begin(), kept.end()));
  timer.done("outliers", "points", inliers->size());

  Cloud::Ptr voxels = voxel_downsample(inliers, params.voxel_size_m);
  timer.done("voxel", "points", voxels->size());

  std::vector<std::uint32_t> triangles = greedy_triangulate(voxels, params);
  timer.done("triangulate", "triangles", triangles.size() / 3);

  triangles = filter_by_perimeter(*voxels, triangles, params.perimeter_factor * params.max_edge_m);
  out.mesh = to_mesh(*voxels, triangles);
  out.cloud = to_point_cloud(*voxels);
  timer.done("perimeter", "triangles", triangles.size() / 3);
  if (triangles.empty()) return make_error(ErrorCode::kEmpty, "the reduction left no triangles");
  if (params.simplify_error_m > 0) {
    simplify_mesh(out.mesh, params.simplify_error_m);
    timer.done("simplify", "triangles", out.mesh.triangle_count());
  }
  return out;
}

PointCloud full_cloud(const RgbdFrame& frame) { return to_point_cloud(*backproject_valid(frame)); }

}  // namespace rgbdcast
