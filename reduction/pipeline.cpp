#include "reduction/pipeline.h"

#include <pcl/console/print.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <new>

#include "base/stopwatch.h"
#include "reduction/openmp_threads.h"
#include "reduction/stages.h"

namespace rgbdcast {

const char* to_string(Preset preset) { return preset == Preset::kPaper ? "paper" : "realtime"; }

Result<Preset> parse_preset(const std::string& name) {
  if (name == "paper") return Preset::kPaper;
  if (name == "realtime") return Preset::kRealtime;
  return make_error(ErrorCode::kInvalidArgument, "preset must be 'paper' or 'realtime', got '" + name + "'");
}

ReductionParams reduction_preset(Preset preset) {
  ReductionParams p;
  p.preset = preset;
  return p;
}

Status ReductionParams::validate() const {
  if (preset == Preset::kRealtime) {
    if (auto st = depth_mesh.validate(); !st) return st;
    if (auto st = filter.validate(); !st) return st;
  }
  auto positive = [](double v) { return std::isfinite(v) && v > 0; };
  if (threads < 0 || threads > 256)
    return make_error(ErrorCode::kInvalidArgument, "threads must be 0..256 (0: OpenMP's default)");
  if (outlier_k < 1 || outlier_k > 1000) return make_error(ErrorCode::kInvalidArgument, "outlier K must be 1..1000");
  if (!positive(outlier_std_mul))
    return make_error(ErrorCode::kInvalidArgument, "outlier std-dev multiplier must be > 0");
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
    out_->push_back({name, unit, count, ms_between(start_, now)});
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

Status check_depth_plausible(const RgbdFrame& frame) {
  std::vector<float> z;
  z.reserve(frame.depth_m.total() / 16 + 1);
  for (int y = 0; y < frame.depth_m.rows; y += 4) {
    const float* row = frame.depth_m.ptr<float>(y);
    for (int x = 0; x < frame.depth_m.cols; x += 4)
      if (row[x] > 0 && std::isfinite(row[x])) z.push_back(row[x]);
  }
  if (z.empty()) return ok_status();  // "no valid depth" is reported by the stages
  std::nth_element(z.begin(), z.begin() + z.size() / 2, z.end());
  const double median = z[z.size() / 2];
  if (median < 0.2 || median > 20) {
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "implausible depth: the median valid depth is %.3g m (an RGB-D sensor sees 0.2-20 m); is "
                  "--depth-scale right (%g raw units per metre)?",
                  median, frame.intrinsics.depth_scale);
    return make_error(ErrorCode::kInvalidInput, buf);
  }
  return ok_status();
}

namespace {

Status check_frame(const RgbdFrame& frame) {
  if (frame.depth_m.empty() || frame.color_rgb.empty() || frame.depth_m.size() != frame.color_rgb.size())
    return make_error(ErrorCode::kInvalidInput, "frame has no images or colour and depth differ in size");
  return check_depth_plausible(frame);
}

}  // namespace

Result<RealtimeReduction> prepare_realtime(const RgbdFrame& frame, const ReductionParams& params) {
  if (auto st = params.validate(); !st) return st.error();
  if (auto st = check_frame(frame); !st) return st.error();
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<StageReport> stages;
  StageTimer timer(&stages);
  // An organized cloud (PCD) carries its own depth image in depth_m (z of each point). With two threads the
  // hierarchy's layout (its tables for this image size, about 0.8 ms) is made during the filter's serial speckle
  // pass, on the otherwise idle core.
  const int threads = openmp_threads(params.threads);
  std::shared_ptr<const DepthMeshLayout> layout;
  std::function<void()> make_layout;
  if (threads > 1)
    make_layout = [&] {
      try {
        layout = make_depth_mesh_layout(frame.depth_m.cols, frame.depth_m.rows, params.depth_mesh);
      } catch (const std::bad_alloc&) {  // the build makes its own
      }
    };
  auto filtered = filter_depth(frame.depth_m, params.filter, threads, make_layout);
  if (!filtered) return filtered.error();
  // valid and filter share one pass; the split of the time is not worth a second one.
  stages.push_back({"valid", "points", filtered->valid, 0.0});
  timer.done("filter", "points", filtered->kept);
  if (filtered->valid == 0) return make_error(ErrorCode::kEmpty, "no valid depth in the frame");
  if (filtered->kept == 0) return make_error(ErrorCode::kEmpty, "the depth filter left no pixels");
  auto hierarchy = DepthMeshHierarchy::build(filtered->depth_m, filtered->vertex_depth_m, frame.intrinsics.pinhole(),
                                             params.depth_mesh, params.threads, std::move(layout));
  if (!hierarchy) return hierarchy.error();
  timer.done("hierarchy", "points", filtered->kept);
  RealtimeReduction r{std::move(*hierarchy), std::move(stages), 0.0};
  r.prepare_ms = ms_since(t0);
  return r;
}

Result<ReducedFrame> extract_realtime(const RealtimeReduction& prepared, const RgbdFrame& frame,
                                      double tolerance_factor, double simplify_px) {
  ReducedFrame out;
  out.stages = prepared.stages;
  StageTimer timer(&out.stages);
  std::vector<Eigen::Vector2i> pixels;
  out.mesh = prepared.hierarchy.extract(tolerance_factor, &pixels, &out.edge_uses);
  out.mesh.colors.resize(pixels.size());
  for (size_t i = 0; i < pixels.size(); ++i) {
    const cv::Vec3b c = frame.color_rgb.at<cv::Vec3b>(pixels[i].y(), pixels[i].x());
    out.mesh.colors[i] = {c[0], c[1], c[2]};
  }
  timer.done("triangulate", "triangles", out.mesh.triangle_count());
  if (simplify_px < 0) simplify_px = prepared.hierarchy.params().simplify_px;
  if (auto st = simplify_realtime(prepared, frame, simplify_px, &out); !st) return st.error();
  return out;
}

Status simplify_realtime(const RealtimeReduction& prepared, const RgbdFrame& frame, double simplify_px,
                         ReducedFrame* reduced) {
  StageTimer timer(&reduced->stages);
  Mesh& mesh = reduced->mesh;
  const DepthMeshParams& mp = prepared.hierarchy.params();
  if (simplify_px > 0 && !mesh.indices.empty()) {
    simplify_image_space(mesh, frame.intrinsics.pinhole(), mp.noise_m_per_m2, simplify_px, mp.texture_deviation_px,
                         &reduced->edge_uses);
    timer.done("simplify", "triangles", mesh.triangle_count());
    reduced->edge_uses.clear();  // the extraction's counts, used up: the mesh has changed
  }
  reduced->cloud.positions = mesh.positions;
  reduced->cloud.colors = mesh.colors;
  if (mesh.indices.empty()) return make_error(ErrorCode::kEmpty, "the reduction left no triangles");
  return ok_status();
}

Result<ReducedFrame> reduce_frame(const RgbdFrame& frame, const ReductionParams& params) {
  if (auto st = params.validate(); !st) return st.error();
  if (params.preset == Preset::kRealtime) {
    auto prepared = prepare_realtime(frame, params);
    if (!prepared) return prepared.error();
    return extract_realtime(*prepared, frame, params.depth_mesh.tolerance_factor);
  }
  // PCL prints its own diagnostics (e.g. greedy triangulation's "not enough neighbours"); rgbdcast reports
  // through Result and the stage report instead.
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  if (auto st = check_frame(frame); !st) return st.error();
  ReducedFrame out;
  StageTimer timer(&out.stages);

  std::vector<int> pixel_of_point;
  Cloud::Ptr valid = backproject_valid(frame, &pixel_of_point);
  timer.done("valid", "points", valid->size());
  if (valid->empty()) return make_error(ErrorCode::kEmpty, "no valid depth in the frame");

  const std::vector<int> kept =
      params.outlier_method == OutlierMethod::kOrganized
          ? statistical_outliers_organized(*valid, pixel_of_point, frame.depth_m.cols, frame.depth_m.rows,
                                           params.outlier_k, params.outlier_std_mul, params.threads)
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
