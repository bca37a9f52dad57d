#pragma once
// The per-triangle maps of the paper's section 3.3, for an undistorted (pinhole) colour image.
//
// A triangle (v0, v1, v2) in the camera frame gets a plane frame: origin v0, x axis along v0->v1, y axis in the
// triangle's plane towards v2. A plane point (x, y) is the camera-frame point v0 + x e1 + y e2 = [e1 e2 v0] (x, y, 1),
// so the plane-to-image homography is H = K [e1 e2 v0]. (In the paper's notation R = [e1 e2 n]^T, t = v0, and
// [r1 r2 -R t] written in the camera frame is exactly [e1 e2 v0].) A is the affine map from plane coordinates onto
// the triangle's corners in the atlas, and M = A H^-1 maps image pixels to atlas texels; the atlas is filled by
// sampling the image at M^-1 (texel) = H A^-1 (texel).
#include <Eigen/Core>
#include <array>

namespace rgbdcast {

struct TriangleTextureMap {
  Eigen::Matrix3d H;                     // plane (x, y, 1) -> image pixel (homogeneous), pixel centres at integers
  Eigen::Matrix3d A;                     // plane (x, y, 1) -> atlas position (affine; last row 0 0 1)
  Eigen::Matrix3d image_from_atlas;      // M^-1 = H A^-1: atlas position -> image pixel (homogeneous)
  std::array<Eigen::Vector2d, 3> plane;  // the triangle's vertices in plane coordinates (metres)
};

// Fails (returns false) for a degenerate triangle (an edge or the area under min_area_m2) or a vertex at z <= 0.
// corners: where v0, v1, v2 go in the atlas (continuous atlas coordinates, texel (i, j) covers [i, i+1] x [j, j+1]).
bool triangle_texture_map(const Eigen::Vector3d& v0, const Eigen::Vector3d& v1, const Eigen::Vector3d& v2,
                          const Eigen::Matrix3d& K, const std::array<Eigen::Vector2d, 3>& corners,
                          TriangleTextureMap* out, double min_area_m2 = 1e-12);

// Area in image pixels of the triangle's projection (0 when a vertex is at z <= 0).
double projected_area_px(const Eigen::Vector3d& v0, const Eigen::Vector3d& v1, const Eigen::Vector3d& v2,
                         const Eigen::Matrix3d& K);

}  // namespace rgbdcast
