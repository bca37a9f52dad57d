#pragma once
// Barycentric coordinates of a 2D point in a triangle (for the atlas tests: where in its triangle an atlas texel is).
#include <Eigen/Dense>
#include <array>

namespace rgbdcast::test {

inline Eigen::Vector3d barycentric(const Eigen::Vector2d& p, const std::array<Eigen::Vector2d, 3>& c) {
  Eigen::Matrix2d T;
  T << c[1] - c[0], c[2] - c[0];
  const Eigen::Vector2d l = T.inverse() * (p - c[0]);
  return {1 - l.x() - l.y(), l.x(), l.y()};
}

}  // namespace rgbdcast::test
