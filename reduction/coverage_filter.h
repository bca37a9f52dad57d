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
  Intrinsics intrinsics;  // pinhole
  cv::Mat depth_m;        // CV_32F, 0 = no depth
  Eigen::Matrix4d camera_to_world = Eigen::Matrix4d::Identity();
};

struct CoverageParams {
  double depth_tolerance_m = 0.03;  // plus 3 sigma of Kinect depth noise at that range
  int border_px = 2;                // vertices this close to an image edge count as not seen
};

// Removes from `mesh` (positions in its own frame, placed in the world by mesh_to_world) every triangle covered by
// one of `earlier`; unreferenced vertices are dropped too. Returns the number of triangles removed.
size_t drop_covered_triangles(Mesh& mesh, const Eigen::Matrix4d& mesh_to_world,
                              const std::vector<CoverageView>& earlier, const CoverageParams& params = {});

}  // namespace rgbdcast
