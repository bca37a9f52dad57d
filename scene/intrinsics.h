#pragma once
// Pinhole intrinsics of an RGB-D camera, with OpenCV-ordered lens distortion and the depth unit.
// Convention everywhere in rgbdcast: camera frame x right, y down, z forward (OpenCV); pixel (0,0) is the centre of
// the top-left pixel.
#include <Eigen/Core>
#include <array>
#include <string>

namespace rgbdcast {

struct Intrinsics {
  double fx = 525.0, fy = 525.0, cx = 319.5, cy = 239.5;
  int width = 640, height = 480;
  std::array<double, 5> distortion{};  // k1 k2 p1 p2 k3 (OpenCV order); all zero = ideal pinhole
  double depth_scale = 5000.0;         // raw depth units per metre (TUM: 5000, millimetre sensors: 1000)
  std::string name = "kinect";

  bool has_distortion() const {
    for (double d : distortion)
      if (d != 0.0) return true;
    return false;
  }
  // Ideal pinhole projection of a camera-frame point (z > 0) to pixel coordinates.
  Eigen::Vector2d project(const Eigen::Vector3d& p) const { return {fx * p.x() / p.z() + cx, fy * p.y() / p.z() + cy}; }
  // Inverse of project for a pixel at a known depth (metres along z).
  Eigen::Vector3d backproject(double u, double v, double depth_m) const {
    return {(u - cx) / fx * depth_m, (v - cy) / fy * depth_m, depth_m};
  }
  Eigen::Matrix3d K() const {
    Eigen::Matrix3d k;
    k << fx, 0, cx, 0, fy, cy, 0, 0, 1;
    return k;
  }
  // The same camera with distortion removed: what a frame is after undistortion.
  Intrinsics pinhole() const {
    Intrinsics p = *this;
    p.distortion = {};
    return p;
  }
  // Vertical field of view in radians (for glTF cameras).
  double yfov_rad() const;
};

}  // namespace rgbdcast
