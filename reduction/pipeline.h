#pragma once
// The paper's reduction of one RGB-D frame (section 3.2): valid pixels -> statistical outlier removal -> voxel
// grid -> greedy projection triangulation -> perimeter filter. Each stage is a separate piece (one file each) that
// reports its output count and time; every parameter defaults to the paper's value.
#include <string>
#include <vector>

#include "input/frame.h"
#include "reduction/depth_filter.h"
#include "reduction/depth_mesh.h"
#include "scene/mesh.h"
#include "scene/result.h"

namespace rgbdcast {

enum class OutlierMethod {
  kKdTree,     // PCL StatisticalOutlierRemoval over a k-d tree of the whole cloud (the paper's)
  kOrganized,  // the same statistic with neighbours from the depth image's pixel window (much faster)
};

// Presets are data: a preset is a ReductionParams value (reduction_preset()), and every field stays an option.
//  - kPaper: the paper's pipeline exactly (valid -> outliers -> voxel -> triangulate -> perimeter).
//  - kRealtime: beyond the paper, on the organized depth image: valid -> filter (flying pixels, speckles) ->
//    triangulate (adaptive RTIN of the depth image, crack-free, tolerance tied to the sensor's noise; see
//    depth_mesh.h). No voxel grid: the adaptive mesh is the downsampling; `points` is its vertex count.
enum class Preset { kPaper, kRealtime };
const char* to_string(Preset preset);
// "paper" or "realtime"; anything else is kInvalidArgument.
Result<Preset> parse_preset(const std::string& name);

struct ReductionParams {
  Preset preset = Preset::kPaper;
  // realtime preset
  DepthFilterParams filter;
  DepthMeshParams depth_mesh;
  // paper preset
  OutlierMethod outlier_method = OutlierMethod::kKdTree;
  int outlier_k = 50;             // neighbours for the mean distance (paper: K = 50)
  double outlier_std_mul = 1.0;   // standard-deviation multiplier (paper: T = 1.0)
  double voxel_size_m = 0.01;     // voxel edge (paper: 1 cm)
  double max_edge_m = 0.05;       // d: greedy triangulation's maximum edge length (search radius)
  double mu = 2.5;                // greedy triangulation: neighbour distance multiplier
  int max_neighbours = 100;       // greedy triangulation: nearest neighbours searched
  int normal_k = 20;              // neighbours for normal estimation
  double perimeter_factor = 3.0;  // drop triangles with perimeter > factor * d (paper: 3)
  double simplify_error_m = 0.0;  // beyond the paper: collapse edges while the surface moves less than this (0 = off)
  // both presets
  int threads = 0;  // OpenMP threads of the parallel stages (reduction/openmp_threads.h); 0 = OpenMP's
                    // default (OMP_NUM_THREADS, else the cores). The service sets cores / reducers.

  // Returns an error naming the first parameter out of range.
  Status validate() const;
};

struct StageReport {
  std::string name;  // valid, outliers, voxel, triangulate, perimeter, simplify (when on), then later stages
  std::string unit;  // "points" or "triangles" (or what the stage counts: "texels", "bytes")
  size_t count = 0;
  double ms = 0.0;
};

struct ReducedFrame {
  PointCloud cloud;  // the voxel-grid cloud, camera frame
  Mesh mesh;         // triangulated, perimeter-filtered; vertex-coloured; camera frame
  std::vector<StageReport> stages;
  // Realtime preset: the triangles using each index slot's edge (edge_use_counts) of mesh as extracted, which the
  // extraction has counted already, for the collapses: kept while mesh is the extracted one (extract_realtime with
  // simplify_px 0, the budget's way), emptied by the collapses (simplify_realtime with simplify_px > 0).
  std::vector<std::uint32_t> edge_uses;
};

// The preset's defaults (kPaper: the paper's values; kRealtime: the realtime preset's).
ReductionParams reduction_preset(Preset preset);

Result<ReducedFrame> reduce_frame(const RgbdFrame& frame, const ReductionParams& params);

// The realtime preset in two steps, for callers that pick the tolerance per frame (a byte budget): prepare() runs
// valid + filter and builds the mesh hierarchy (the costly part, once); extract() gives the mesh at a tolerance
// factor, vertex-coloured from the frame, with the stages so far plus "triangulate" (and "simplify": the edge
// collapses at simplify_px, the params' DepthMeshParams::simplify_px when negative).
struct RealtimeReduction {
  DepthMeshHierarchy hierarchy;
  std::vector<StageReport> stages;  // valid, filter
  double prepare_ms = 0.0;
};
Result<RealtimeReduction> prepare_realtime(const RgbdFrame& frame, const ReductionParams& params);
Result<ReducedFrame> extract_realtime(const RealtimeReduction& prepared, const RgbdFrame& frame,
                                      double tolerance_factor, double simplify_px = -1);
// The collapses alone, on a mesh extract_realtime gave with simplify_px 0 (for a caller that uses the mesh before
// them too): stage "simplify" appended, the cloud updated. Errors: kEmpty when no triangle is left.
Status simplify_realtime(const RealtimeReduction& prepared, const RgbdFrame& frame, double simplify_px,
                         ReducedFrame* reduced);

// Depth sanity: an error naming --depth-scale when the frame's valid depths are implausible for an RGB-D sensor
// (median outside 0.2-20 m), instead of a mesh of garbage.
Status check_depth_plausible(const RgbdFrame& frame);

// The full cloud of a frame (every valid pixel), for the paper's full-cloud comparison.
PointCloud full_cloud(const RgbdFrame& frame);

}  // namespace rgbdcast
