#include "renderer/render_camera.h"

#include <cmath>
#include <string>

namespace rgbdcast {

Status check_camera(const ViewCamera& c) {
  if (c.width < 1 || c.height < 1 || c.width > kMaxImageSize || c.height > kMaxImageSize)
    return make_error(ErrorCode::kInvalidArgument, "image size " + std::to_string(c.width) + "x" +
                                                       std::to_string(c.height) + " is outside 1.." +
                                                       std::to_string(kMaxImageSize) + " pixels per side");
  if (!std::isfinite(c.fx) || !std::isfinite(c.fy) || !std::isfinite(c.cx) || !std::isfinite(c.cy))
    return make_error(ErrorCode::kInvalidArgument, "camera intrinsics must be finite numbers");
  if (!(c.fx > 0.0) || !(c.fy > 0.0)) return make_error(ErrorCode::kInvalidArgument, "camera fx and fy must be > 0");
  if (!c.camera_to_world.allFinite())
    return make_error(ErrorCode::kInvalidArgument, "camera pose contains NaN or infinite values");
  const Eigen::Matrix3d r = c.camera_to_world.block<3, 3>(0, 0);
  if (!(r.transpose() * r).isApprox(Eigen::Matrix3d::Identity(), 1e-4) || r.determinant() < 0.0)
    return make_error(ErrorCode::kInvalidArgument, "camera pose rotation is not a rotation matrix");
  if (!std::isfinite(c.near_m) || !std::isfinite(c.far_m) || !(c.near_m > 0.0) || !(c.far_m > c.near_m))
    return make_error(ErrorCode::kInvalidArgument, "camera near/far planes must satisfy 0 < near < far");
  return ok_status();
}

Status check_options(const RenderOptions& o) {
  if (!std::isfinite(o.point_size_px) || o.point_size_px < 1.0f || o.point_size_px > 255.0f)
    return make_error(ErrorCode::kInvalidArgument, "point size must be between 1 and 255 pixels");
  return ok_status();
}

Eigen::Matrix4d clip_from_camera(const ViewCamera& c) {
  // Framebuffer x = (x_ndc + 1) * W / 2 and the pixel centred at u sits at framebuffer x = u + 0.5, so
  // x_ndc = (2u + 1) / W - 1 with u = fx x / z + cx; times w = z gives the row below. Same for y (already down).
  const double w = c.width, h = c.height, n = c.near_m, f = c.far_m;
  Eigen::Matrix4d p = Eigen::Matrix4d::Zero();
  p(0, 0) = 2.0 * c.fx / w;
  p(0, 2) = (2.0 * c.cx + 1.0) / w - 1.0;
  p(1, 1) = 2.0 * c.fy / h;
  p(1, 2) = (2.0 * c.cy + 1.0) / h - 1.0;
  // depth = A + B / z: 0 at near, 1 at far.
  p(2, 2) = f / (f - n);
  p(2, 3) = -n * f / (f - n);
  p(3, 2) = 1.0;
  return p;
}

}  // namespace rgbdcast
