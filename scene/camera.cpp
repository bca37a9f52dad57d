#include "scene/camera.h"

#include <cmath>

namespace rgbdcast {

double Intrinsics::yfov_rad() const { return 2.0 * std::atan2(0.5 * height, fy); }

ViewCamera ViewCamera::from_capture(const CaptureCamera& cam) {
  return from_capture(cam, cam.intrinsics.width, cam.intrinsics.height);
}

ViewCamera ViewCamera::from_capture(const CaptureCamera& cam, int width, int height) {
  const Intrinsics& k = cam.intrinsics;
  const double sx = static_cast<double>(width) / k.width, sy = static_cast<double>(height) / k.height;
  ViewCamera v;
  v.fx = k.fx * sx;
  v.fy = k.fy * sy;
  // Pixel centres: (c + 0.5) * s - 0.5 keeps the image edges aligned when resizing.
  v.cx = (k.cx + 0.5) * sx - 0.5;
  v.cy = (k.cy + 0.5) * sy - 0.5;
  v.width = width;
  v.height = height;
  v.camera_to_world = cam.camera_to_world;
  return v;
}

Result<ViewCamera> ViewCamera::look_at(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                                       const Eigen::Vector3d& up, double vertical_fov_deg, int width, int height) {
  if (!eye.allFinite() || !target.allFinite() || !up.allFinite() || !std::isfinite(vertical_fov_deg))
    return make_error(ErrorCode::kInvalidArgument, "camera parameters must be finite numbers");
  if (width < 1 || height < 1 || width > kMaxImageSize || height > kMaxImageSize)
    return make_error(ErrorCode::kInvalidArgument,
                      "image size must be between 1 and " + std::to_string(kMaxImageSize) + " pixels per side");
  if (!(vertical_fov_deg > 0.5 && vertical_fov_deg <= kMaxVerticalFovDeg))
    return make_error(ErrorCode::kInvalidArgument, "field of view must be above 0.5 and at most 179 degrees");
  const Eigen::Vector3d forward = target - eye;
  if (forward.norm() < 1e-9) return make_error(ErrorCode::kInvalidArgument, "eye and target are the same point");
  const Eigen::Vector3d z = forward.normalized();
  if (up.norm() < 1e-9 || z.cross(up.normalized()).norm() < 1e-6)
    return make_error(ErrorCode::kInvalidArgument, "up vector is zero or parallel to the view direction");
  // Camera convention: y points down in the image, so the camera's y axis is the negated up direction.
  // x = y \times z with y = -up (right-handed x right, y down, z forward); z x (-up) would mirror both x and y.
  const Eigen::Vector3d x = z.cross(up.normalized()).normalized();
  const Eigen::Vector3d y = z.cross(x);
  ViewCamera v;
  v.width = width;
  v.height = height;
  v.fy = 0.5 * height / std::tan(0.5 * vertical_fov_deg * M_PI / 180.0);
  v.fx = v.fy;
  v.cx = 0.5 * width - 0.5;
  v.cy = 0.5 * height - 0.5;
  v.camera_to_world.setIdentity();
  v.camera_to_world.block<3, 1>(0, 0) = x;
  v.camera_to_world.block<3, 1>(0, 1) = y;
  v.camera_to_world.block<3, 1>(0, 2) = z;
  v.camera_to_world.block<3, 1>(0, 3) = eye;
  return v;
}

Eigen::Matrix4d ViewCamera::world_to_camera() const {
  Eigen::Matrix4d inv = Eigen::Matrix4d::Identity();
  const Eigen::Matrix3d r = camera_to_world.block<3, 3>(0, 0);
  inv.block<3, 3>(0, 0) = r.transpose();
  inv.block<3, 1>(0, 3) = -r.transpose() * camera_to_world.block<3, 1>(0, 3);
  return inv;
}

}  // namespace rgbdcast
