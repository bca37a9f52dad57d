#pragma once
// The realtime preset's first stage on the organized depth image (beyond the paper, which works on an unorganized
// cloud): an O(pixels) depth filter that leaves the depth the RTIN (reduction/depth_mesh.h) triangulates.
#include <cstddef>
#include <functional>
#include <opencv2/core.hpp>

#include "scene/result.h"

namespace rgbdcast {

struct DepthFilterParams {
  double jump_relative = 0.08;  // adjacent pixels whose depths differ by more than this fraction are discontinuous
  int min_region_px = 64;       // connected regions (across continuous neighbours) smaller than this are speckles
  int min_support = 3;          // a pixel with fewer continuous 8-neighbours is a flying pixel (or a speckle)
  int gap_fill_px = 3;          // gaps in one surface within this radius are filled with the surface's depth (0: off)
  int smooth_px = 0;            // vertex depth: mean inverse depth over this radius on one surface (0: off; on
                                // fr1/xyz frame 0 a radius of 2 gave 8-37 % more triangles at 2-8 sigma)

  // An error naming the first parameter out of range.
  Status validate() const;
};

struct DepthFilterResult {
  cv::Mat depth_m;         // CV_32FC1, the kept depth and the filled gaps (0 where removed or invalid)
  cv::Mat vertex_depth_m;  // CV_32FC1, depth_m smoothed within one surface: where mesh vertices sit (without
                           // smoothing, depth_m itself: the same buffer)
  size_t valid = 0, flying = 0, speckles = 0, kept = 0, filled = 0;
};

// filter: drops flying pixels (too few continuous 8-neighbours) and speckles (small continuous regions, through
// OpenCV's filterSpeckles on log depth, where a relative jump is an absolute difference), then fills small gaps
// inside one surface (never between two), so that the mesh need not trace every missing pixel. depth_m: CV_32FC1
// metres, 0 = no depth. O(pixels).
// threads: row bands on plain threads for the per-pixel passes (1: this thread alone). beside_speckles: the caller's
// work, run on a thread of its own during the speckle pass (serial: the second core is otherwise idle there) and
// joined before that pass ends; it must not throw.
Result<DepthFilterResult> filter_depth(const cv::Mat& depth_m, const DepthFilterParams& params, int threads = 1,
                                       const std::function<void()>& beside_speckles = {});

}  // namespace rgbdcast
