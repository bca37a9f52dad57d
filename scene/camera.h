#pragma once
// Cameras: where a frame was captured (CaptureCamera) and where an operator looks from (ViewCamera).
// World frame convention: the capture camera frame of the first keyframe (x right, y down, z forward).
// glTF uses y up and -z forward; kCameraToGltf converts (a rotation of 180 degrees about x).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>

#include "scene/intrinsics.h"
#include "scene/result.h"

namespace rgbdcast {

struct CaptureCamera {
  Intrinsics intrinsics;  // pinhole, after undistortion
  Eigen::Matrix4d camera_to_world = Eigen::Matrix4d::Identity();
  double timestamp = 0.0;  // seconds, as in the source (0 if unknown)
  std::string source;      // e.g. "rgb/1305031102.175304.png"
  int frame_index = -1;
};

// diag(1, -1, -1): maps camera-convention coordinates (y down, z forward) to glTF's (y up, -z forward) and back.
inline Eigen::Matrix4d camera_to_gltf() {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m(1, 1) = -1.0;
  m(2, 2) = -1.0;
  return m;
}

// A camera to render from: pinhole intrinsics at a pose. Rendering a scene with the capture camera's intrinsics at
// the capture pose reproduces the captured view pixel for pixel.
struct ViewCamera {
  double fx = 525.0, fy = 525.0, cx = 319.5, cy = 239.5;
  int width = 640, height = 480;
  Eigen::Matrix4d camera_to_world = Eigen::Matrix4d::Identity();
  double near_m = 0.05, far_m = 100.0;

  static ViewCamera from_capture(const CaptureCamera& cam);
  // The capture camera's view at another image size (intrinsics scaled).
  static ViewCamera from_capture(const CaptureCamera& cam, int width, int height);
  // Looking from eye at target; up is a world direction (default -y: world up in camera convention).
  // Fails on NaN/inf, eye == target, up parallel to the view direction, vertical fov outside (0.5, 179] degrees,
  // or a bad size.
  static Result<ViewCamera> look_at(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                                    const Eigen::Vector3d& up, double vertical_fov_deg, int width, int height);
  Eigen::Matrix4d world_to_camera() const;
};

// Widest vertical field of view of a look-at camera, in degrees. A pinhole projection is defined for any angle below
// 180 (fy = h / 2 / tan(fov / 2) stays positive and finite: 0.0044 h at 179 degrees); 179 is the whole-degree
// maximum that the CLI (--fov), the service (fov=) and the OpenAPI document all state.
inline constexpr double kMaxVerticalFovDeg = 179.0;

// Largest image edge any renderer or service accepts.
inline constexpr int kMaxImageSize = 8192;

}  // namespace rgbdcast
