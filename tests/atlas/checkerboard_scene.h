#pragma once
// A synthetic capture for texture tests: a planar checkerboard seen obliquely by a pinhole camera, ray-cast
// (4x4 supersampled) into an RGB image, and a coarse mesh of large triangles on the plane.
#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "scene/intrinsics.h"
#include "scene/mesh.h"

namespace rgbdcast::test {

struct CheckerScene {
  Intrinsics k;                  // 640x480 pinhole
  Eigen::Vector3d origin, U, V;  // plane point (s, t) = origin + s U + t V (camera frame, metres)
  double square_m = 0.1;
  double half_s = 0.6, half_t = 0.3;  // extent of the board
  cv::Mat image;                      // CV_8UC3 RGB
  Mesh mesh;                          // vertex grid on the board, large triangles

  // 1 for a light square, 0 for a dark one.
  int checker(double s, double t) const;
  // Distance (metres, in the plane) from (s, t) to the nearest checker edge line.
  double edge_distance_m(double s, double t) const;
  // Plane coordinates of the point where the ray through pixel (u, v) meets the plane.
  Eigen::Vector2d plane_at_pixel(double u, double v) const;
  Eigen::Vector2d plane_of(const Eigen::Vector3d& X) const;
};

// The board's normal makes `angle_deg` with the optical axis; quads_s x quads_t quads, two triangles each. The board
// spans |s| <= half_s, |t| <= half_t metres (the default one fills part of the view; a larger one fills it).
CheckerScene make_checker_scene(double angle_deg, int quads_s, int quads_t, double half_s = 0.6, double half_t = 0.3);

// The board tessellated the way the realtime preset meshes a depth image: right isosceles triangles in image space
// with vertices at pixel centres (right_triangle_mesh.h), blocks of min_side_px..max_side_px (mixed by a fixed
// pattern), four triangles with diagonal legs (side / sqrt 2) in blocks of at least 2 min_side_px, else two with
// axis-aligned legs: legs of min_side .. max_side px. Blocks with a corner off the board are dropped.
Mesh checker_right_triangle_mesh(const CheckerScene& scene, int min_side_px, int max_side_px);

}  // namespace rgbdcast::test
