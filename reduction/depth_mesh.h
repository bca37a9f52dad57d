#pragma once
// The realtime preset's triangulation of the organized depth image (beyond the paper, which works on an unorganized
// cloud), after the depth filter (reduction/depth_filter.h): an adaptive, crack-free triangulation of the depth
// image, a right-triangulated irregular network (RTIN) over tiles of 2^k pixels.
//
// Why inverse depth: a plane in the camera frame projects to a depth image whose inverse depth w = 1/z is an affine
// function of the pixel (u, v). So a triangle with its three vertices at pixel centres is a planar 3D triangle exactly
// when w is interpolated linearly across it, and a pixel's distance from the triangle along its ray is
// |z - 1/w_plane|. Kinect-class depth noise sigma_z = 1.425e-3 z^2 m is, to first order, a constant sigma_w =
// 1.425e-3 1/m in inverse depth (sigma_w = sigma_z / z^2). So "metric distance above sensor noise" is one constant
// tolerance in w, and the error of a triangle over all its pixels reduces to sums (moments) that add up from the
// children: the whole hierarchy's errors cost O(pixels).
//
// Contract of the mesh: vertices at pixel centres (pushed a pixel outwards on the mesh's boundary, so that every
// pixel of a covered region is covered at the capture pose, its border pixels included, and the one-pixel band of
// flying pixels the filter drops along a discontinuity too); no T-junctions (the RTIN's
// conforming splits, shared across tiles); every interior edge has exactly two triangles; no triangle spans a depth
// discontinuity; deterministic (no randomness, no thread-order dependence).
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "scene/intrinsics.h"
#include "scene/mesh.h"
#include "scene/result.h"

namespace rgbdcast {

struct RtinTable;        // the implicit triangle tree of one tile size (depth_mesh.cpp)
struct DepthMeshLayout;  // the tables a hierarchy's build needs for one image size and parameters (depth_mesh.cpp)

struct DepthMeshParams {
  double tolerance_factor = 2.0;       // split while a triangle's RMS distance from its pixels exceeds this many sigma
  double noise_m_per_m2 = 1.425e-3;    // sensor depth noise: sigma_z = noise * z^2 (Kinect-class)
  double jump_relative = 0.08;         // as DepthFilterParams: per pixel of edge length
  double boundary_px_per_sigma = 1.0;  // a border triangle dropped whole loses its inner valid pixels: this many cost
                                       // as much as one sigma of fit error
  double boundary_max_lost_px = 2.0;   // ... and it splits, whatever the tolerance, when it would lose more than this
                                       // many (a budget then trades interior detail, not coverage, for bytes)
  // After extraction (extract_realtime): edge collapses while the mesh moves less than this many pixels across the
  // image or sigma of inverse depth (meshoptimizer's quadric simplifier in (u, v, w / sigma_w) space; 0: off). The
  // RTIN follows a discontinuity or a hole's edge in one-pixel steps, 2-4 triangles a pixel of outline; the
  // collapses turn each straight run into a few long edges. Away from the outline, vertices move only where the
  // surface is close enough to fronto-parallel that affine texturing stays near texture_deviation_px on triangles
  // of up to 48 pixels (reduction/simplify.cpp). 2 px rather than 1 (BENCHMARKS.md, "Realtime preset against the paper
  // preset"): at the 40 kB budget the frames whose outline the budget straightens take one collapse run instead of two
  // (realtime_bench speed, median ms: fr2 pair 35.4 -> 27.9, augmented ICL 34.8 -> 28.5, fr3 39.0 -> 33.4, TUM fr1/xyz
  // 200-319 26.0 -> 24.6), with capture-pose coverage and PSNR within 0.1 dB or better except ICL-NUIM's all-valid PSNR
  // (38.80 -> 37.56 dB), and novel views at 40 kB 21.80 -> 21.85 dB on augmented ICL and 9.36 on TUM, as before.
  double simplify_px = 2.0;
  double max_hole_fraction = 0.5;     // a triangle may bridge invalid pixels up to this fraction of its pixels
  double texture_deviation_px = 0.5;  // split while affine texture interpolation deviates more (0: no such split)
  // The fit error is judged on triangles whose legs are at least this long (8 pixels or more); smaller ones split
  // only for holes, depth jumps, texture deviation and the border rule (their error is 0). A Kinect-class sensor
  // matches its pattern over a window of about 9x9 pixels, so below that its depth holds no surface detail and a
  // fit measures noise; skipping those levels (87 % of the tree's triangles) is most of the hierarchy's time.
  // 0 or 1: every level.
  double fit_min_leg_px = 4.0;
  int tile_px = 128;  // largest triangle legs; a power of two, 2..128
  // Boundary vertices move this far outwards (0: none; at most 2). Half a pixel covers the border pixels; a pixel
  // also covers the flying pixels the filter dropped beside them (valid depth the sensor gave, mixed between two
  // surfaces): on TUM fr1/xyz frame 0 at 40 kB coverage 0.988 -> 0.994 and PSNR over all valid pixels +1.8 dB, for
  // 0.1 dB less over the pixels drawn (edge pixels are the hardest to texture). 1.5 px: at 40 kB, capture coverage
  // min 0.9924 -> 0.9958 over the 26 shared frames for 0.0-0.45 dB less drawn, and at the novel views of augmented
  // ICL and TUM fr1/xyz (bench/realtime_bench --only rd) coverage 0.9782 -> 0.9809 and 0.7221 -> 0.7271, all-valid
  // PSNR 20.79 -> 21.80 and 9.27 -> 9.36 dB (the full cloud as 2 px splats: 21.01 and 9.27).
  double boundary_push_px = 1.5;

  Status validate() const;
};

// What a hierarchy's build needs that depends only on the image's size and the parameters (the triangle tree, its
// per-level edge lengths and depth ratios, grid offsets): about 0.8 ms at 640x480, made beside the depth filter by
// prepare_realtime so that a frame's build does not wait for it. Immutable; params must be valid.
std::shared_ptr<const DepthMeshLayout> make_depth_mesh_layout(int width, int height, const DepthMeshParams& params);

// The RTIN's error hierarchy for one depth image: built once (O(pixels)), then extracted at any tolerance factor
// in O(output). Holds no reference to the input.
class DepthMeshHierarchy {
 public:
  // depth_m: CV_32FC1 metres (0 = none), the pixels the fit is judged on; vertex_depth_m: where vertices sit (the
  // same validity), as filter_depth leaves them; pinhole: the depth image's camera; threads: OpenMP threads
  // (reduction/openmp_threads.h, 0 = OpenMP's default).
  // layout: make_depth_mesh_layout's for this image size and these parameters (made here when null or not theirs).
  static Result<DepthMeshHierarchy> build(const cv::Mat& depth_m, const cv::Mat& vertex_depth_m,
                                          const Intrinsics& pinhole, const DepthMeshParams& params, int threads = 0,
                                          std::shared_ptr<const DepthMeshLayout> layout = nullptr);

  // The triangles at `tolerance_factor` (sigma units), as a vertex-coloured-less mesh in the camera frame (metres):
  // positions and indices only, counter-clockwise seen from the camera. `pixels` (optional) gets each vertex's
  // grid pixel (u, v) before the boundary push. Empty when nothing is representable.
  // `edge_uses` (optional) gets edge_use_counts(indices) of the mesh (counted for the boundary push anyway).
  Mesh extract(double tolerance_factor, std::vector<Eigen::Vector2i>* pixels = nullptr,
               std::vector<std::uint32_t>* edge_uses = nullptr) const;
  // The triangle counts at every tolerance from `tolerance_min` up, from one walk at it (for budget searches):
  // a triangle is emitted at t while its own error <= t < its parent's. Tolerances are binned by their float's top
  // 16 bits (128 bins an octave, 0.54 % apart); a bin's count is exact at its top (TriangleCounts::top).
  class TriangleCounts {
   public:
    // The count at `tolerance_factor` when it is the minimum or a bin's top; else at the top of its bin (<= the
    // exact count). Tolerances below the minimum count as the minimum.
    size_t at(double tolerance_factor) const;
    // The smallest tolerance in [minimum, tolerance_max] with at most `triangles` (the minimum, or a bin's top);
    // tolerance_max's bin top when none is.
    double smallest_with_at_most(double triangles, double tolerance_max) const;
    double minimum() const { return min_; }  // the walk's tolerance
    // The top of a tolerance's bin: what smallest_with_at_most answers with that tolerance as its maximum when no
    // smaller tolerance will do.
    static double bin_top_of(double tolerance_factor);

   private:
    friend class DepthMeshHierarchy;
    double min_ = 0;
    size_t at_min_ = 0;
    int first_bin_ = 0;
    std::vector<std::int64_t> counts_;  // by bin - first_bin_
  };
  // threads: workers over the tiles (plain threads joined here; 1: this thread alone).
  TriangleCounts counts(double tolerance_min, int threads = 1) const;

  int width() const { return width_; }
  const DepthMeshParams& params() const { return params_; }
  int height() const { return height_; }

 private:
  template <class Emit>
  void walk(double tolerance_factor, Emit&& emit) const;

  int width_ = 0, height_ = 0, tile_ = 0, tiles_x_ = 0, tiles_y_ = 0, grid_w_ = 0;
  Intrinsics k_;
  DepthMeshParams params_;
  std::vector<float> depth_;           // grid (grid_w_ x grid_h), metres, 0 = none
  std::vector<float> error_;           // grid: Martini-style max error (sigma units) at each hypotenuse midpoint
  std::vector<std::uint8_t> leaf_ok_;  // per tile, per leaf triangle: emittable
  std::shared_ptr<const RtinTable> table_;
};

}  // namespace rgbdcast
