#pragma once
// Camera and option checks shared by the backends, and the projection that makes a render at the capture camera
// reproduce the captured image pixel for pixel.
//
// Contract of clip_from_camera(): a camera-frame point (x, y, z), z > 0, that projects to pixel (u, v) with
// u = fx*x/z + cx, v = fy*y/z + cy lands in the pixel whose centre is (u, v); pixel centres are at integer
// coordinates, (0,0) is the centre of the top-left pixel. Clip space is Vulkan's: x right, y DOWN, depth 0 at near_m
// and 1 at far_m, w = z. The OpenGL backend uses the same matrix with glClipControl(GL_UPPER_LEFT, GL_ZERO_TO_ONE)
// and reads rows back flipped, so both give the top row first.
#include <Eigen/Core>

#include "renderer/renderer.h"

namespace rgbdcast {

// Fails (kInvalidArgument) on a size outside 1..kMaxImageSize, non-finite intrinsics or pose, fx or fy <= 0,
// a pose whose rotation is not orthonormal, or near/far not 0 < near < far.
Status check_camera(const ViewCamera& camera);
// Fails (kInvalidArgument) on a point size outside [1, 255] or not finite.
Status check_options(const RenderOptions& options);

Eigen::Matrix4d clip_from_camera(const ViewCamera& camera);

// Depth-buffer value (0..1, as produced by clip_from_camera) to metres along z; 0 for the cleared value 1.
inline float linear_depth_m(float d, double near_m, double far_m) {
  if (d >= 1.0f) return 0.0f;
  return static_cast<float>(near_m * far_m / (far_m - d * (far_m - near_m)));
}

}  // namespace rgbdcast
