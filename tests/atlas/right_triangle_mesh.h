#pragma once
// A stand-in for the realtime preset's adaptive triangulation of the depth image (an RTIN), to test and measure the
// footprint atlas on realistic input before that lands: a quadtree of square blocks over the image, each leaf split
// into right isosceles triangles with their vertices at pixel centres, either two along a diagonal (axis-aligned legs
// of the block's side) or four around the block's centre (diagonal legs of side / sqrt 2). Leaves of both kinds are
// mixed (a checker pattern over the blocks). Unlike an RTIN it may leave T-junctions: the texture does not care.
#include <functional>
#include <opencv2/core.hpp>

#include "scene/intrinsics.h"
#include "scene/mesh.h"

namespace rgbdcast::test {

// The camera-frame point seen at pixel centre (x, y); false where there is none.
using PointAt = std::function<bool(int x, int y, Eigen::Vector3f* point)>;
// Whether the block with top-left pixel centre (x, y) and side `side` px is split into four.
using SplitBlock = std::function<bool(int x, int y, int side)>;

struct RightTriangleMeshOptions {
  int max_side_px = 64;           // root blocks (a power of two)
  int min_side_px = 2;            // no block smaller than this (>= 2, so a centre vertex sits on a pixel centre)
  int min_diagonal_side_px = 2;   // leaves smaller than this are always split along a diagonal (two triangles)
  double max_depth_ratio = 1.05;  // a triangle whose vertices' depths differ by more is dropped (a depth jump)
};

// width x height image. Blocks that leave the image are split down to min_side_px, then dropped. Triangles with a
// vertex without a point are dropped. Deterministic.
Mesh right_triangle_mesh(int width, int height, const PointAt& point_at, const SplitBlock& split,
                         const RightTriangleMeshOptions& options = {});

// The mesh of a depth image (CV_32F metres, 0 = none) seen by pinhole `k`: a block is split while a corner has no
// depth, or some pixel of it departs from the bilinear interpolation of its corners' depths by more than
// tolerance_factor * 1.425e-3 z^2 m (Kinect-class depth noise), or it holds a pixel without depth, or its corners'
// depths differ by more than max_depth_ratio (so that only real jumps are dropped).
Mesh right_triangle_mesh_of_depth(const cv::Mat& depth_m, const Intrinsics& k, double tolerance_factor = 1.0,
                                  const RightTriangleMeshOptions& options = {});

}  // namespace rgbdcast::test
