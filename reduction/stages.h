#pragma once
// The reduction's stages, one file each (reduction/<stage>.cpp). Each takes the previous stage's output and returns
// its own; counts and times are taken by the pipeline.
#include <cstdint>
#include <vector>

#include "input/frame.h"
#include "reduction/cloud.h"
#include "reduction/pipeline.h"

namespace rgbdcast {

// valid: every pixel with depth > 0 (or a finite organized point), coloured. Camera frame, metres.
Cloud::Ptr backproject_valid(const RgbdFrame& frame);

// outliers: PCL StatisticalOutlierRemoval. A point is kept when its mean distance to its k nearest neighbours is
// at most mean + std_mul * stddev of those mean distances over the cloud.
Cloud::Ptr remove_statistical_outliers(const Cloud::ConstPtr& cloud, int k, double std_mul);

// voxel: PCL VoxelGrid; one point (the centroid, colours averaged) per occupied voxel of edge voxel_size_m.
Cloud::Ptr voxel_downsample(const Cloud::ConstPtr& cloud, double voxel_size_m);

// triangulate: normals from normal_k neighbours (oriented towards the camera at the origin), then PCL's
// GreedyProjectionTriangulation (Marton et al. 2009) with search radius max_edge_m. Returns vertex indices into
// `cloud`, three per triangle, wound counter-clockwise as seen from the camera.
std::vector<std::uint32_t> greedy_triangulate(const Cloud::ConstPtr& cloud, const ReductionParams& params);

// perimeter: keeps the triangles whose perimeter is at most max_perimeter_m (paper: 3 d).
std::vector<std::uint32_t> filter_by_perimeter(const Cloud& cloud, const std::vector<std::uint32_t>& triangles,
                                               double max_perimeter_m);

}  // namespace rgbdcast
