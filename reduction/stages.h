#pragma once
// The reduction's stages, one file each (reduction/<stage>.cpp). Each takes the previous stage's output and returns
// its own; counts and times are taken by the pipeline.
#include <cstdint>
#include <vector>

#include "input/frame.h"
#include "reduction/cloud.h"
#include "reduction/pipeline.h"

namespace rgbdcast {

// valid: every pixel with depth > 0 (or a finite organized point), coloured, in row-major pixel order. Camera
// frame, metres. pixel_of_point (optional) receives each point's pixel index v * width + u.
Cloud::Ptr backproject_valid(const RgbdFrame& frame, std::vector<int>* pixel_of_point = nullptr);

// outliers: PCL StatisticalOutlierRemoval. A point is kept when its mean distance to its k nearest neighbours is
// at most mean + std_mul * stddev of those mean distances over the cloud. Returns the kept indices, ascending.
std::vector<int> statistical_outliers_kdtree(const Cloud::ConstPtr& cloud, int k, double std_mul);

// outliers, organized variant: the same statistic with the neighbours searched among the valid pixels of the image
// window around each point's pixel (see organized_outlier_removal.cpp), on `threads` OpenMP threads
// (reduction/openmp_threads.h). Returns the kept indices, ascending.
std::vector<int> statistical_outliers_organized(const Cloud& cloud, const std::vector<int>& pixel_of_point, int width,
                                                int height, int k, double std_mul, int threads = 0);

// voxel: PCL VoxelGrid; one point (the centroid, colours averaged) per occupied voxel of edge voxel_size_m.
Cloud::Ptr voxel_downsample(const Cloud::ConstPtr& cloud, double voxel_size_m);

// triangulate: normals from normal_k neighbours (oriented towards the camera at the origin), then PCL's
// GreedyProjectionTriangulation (Marton et al. 2009) with search radius max_edge_m. Returns vertex indices into
// `cloud`, three per triangle, wound counter-clockwise as seen from the camera. Normals on params.threads threads.
std::vector<std::uint32_t> greedy_triangulate(const Cloud::ConstPtr& cloud, const ReductionParams& params);

// perimeter: keeps the triangles whose perimeter is at most max_perimeter_m (paper: 3 d).
std::vector<std::uint32_t> filter_by_perimeter(const Cloud& cloud, const std::vector<std::uint32_t>& triangles,
                                               double max_perimeter_m);

// simplify: error-bounded edge collapses (meshoptimizer) with the borders locked; 0 leaves the mesh as it is.
void simplify_mesh(Mesh& mesh, double max_error_m);
// The realtime mesh's edge collapses in (u, v, w / w_unit) space, borders free (simplify.cpp); returns triangles.
// edge_uses: edge_use_counts(mesh.indices) when the caller has it (counted here otherwise).
size_t simplify_image_space(Mesh& mesh, const Intrinsics& k, double w_unit, double max_error, double texture_limit_px,
                            const std::vector<std::uint32_t>* edge_uses = nullptr);

}  // namespace rgbdcast
