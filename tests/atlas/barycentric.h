#pragma once
// Barycentric coordinates of a 2D point in a triangle (for the atlas tests: where in its triangle an atlas texel is).
#include <Eigen/Dense>
#include <array>
#include <cmath>

namespace rgbdcast::test {

inline Eigen::Vector3d barycentric(const Eigen::Vector2d& p, const std::array<Eigen::Vector2d, 3>& c) {
  Eigen::Matrix2d T;
  T << c[1] - c[0], c[2] - c[0];
  const Eigen::Vector2d l = T.inverse() * (p - c[0]);
  return {1 - l.x() - l.y(), l.x(), l.y()};
}

// Whether an atlas triangle (corners q in texels, vertices v in the camera frame) is textured from a frame patch
// (TextureMode::kFootprint): its corners are its vertices' projections moved by one whole-texel shift, on texel
// centres (cell corners sit on texel corners). *shift = q - projection.
inline bool is_patch_triangle(const std::array<Eigen::Vector2d, 3>& q, const std::array<Eigen::Vector3d, 3>& v,
                              const Eigen::Matrix3d& K, Eigen::Vector2d* shift) {
  std::array<Eigen::Vector2d, 3> d;
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector3d h = K * v[i];
    d[i] = q[i] - h.head<2>() / h.z();
  }
  *shift = d[0];
  const bool on_centre = std::abs(q[0].x() - std::floor(q[0].x()) - 0.5) < 1e-2;
  return on_centre && (d[1] - d[0]).norm() < 1e-3 && (d[2] - d[0]).norm() < 1e-3;
}

}  // namespace rgbdcast::test
