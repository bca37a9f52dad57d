#pragma once
// Multi-view scenes: a triangle of a new keyframe that an earlier keyframe already saw (all three vertices project
// inside that keyframe's image onto valid depth that agrees with them) adds bytes but nothing new to see; this filter
// drops such triangles.
#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <vector>

#include "scene/intrinsics.h"
#include "scene/mesh.h"

namespace rgbdcast {

struct CoverageView {
  Intrinsics intrinsics;                 // pinhole
  cv::Mat depth_m;                       // CV_32F, 0 = no depth
  Eigen::Matrix4d camera_to_world = Eigen::Matrix4d::Identity();
};

struct CoverageParams {
  double depth_tolerance_m = 0.03;   // plus 3 sigma of Kinect depth noise at that range
  int border_px = 2;                 // vertices this close to an image edge count as not seen
  // Resolution-aware coverage (0: off; otherwise >= 1). An earlier view covers a triangle only when the triangle's
  // area in that view's image is at least 1/finer_ratio of its area in the mesh's own image (`own`: the pinhole
  // intrinsics of the camera whose frame the mesh positions are in). A surface the new keyframe sees at finer_ratio
  // x the pixels of every earlier view that saw it (closer, or more head-on) is kept: the earlier keyframe's texture
  // holds it that much coarser, so re-sending it adds detail, not just bytes.
  double finer_ratio = 0;
  Intrinsics own;
};

// Removes from `mesh` (positions in its own frame, placed in the world by mesh_to_world) every triangle covered by
// one of `earlier`; unreferenced vertices are dropped too. Returns the number of triangles removed.
size_t drop_covered_triangles(Mesh& mesh, const Eigen::Matrix4d& mesh_to_world,
                              const std::vector<CoverageView>& earlier, const CoverageParams& params = {});

}  // namespace rgbdcast
