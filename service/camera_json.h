#pragma once
// A full camera as robots and viewers state it: intrinsics and a camera-to-world pose, in JSON.
//
//   {"fx": 517.3, "fy": 516.5, "cx": 318.6, "cy": 255.3, "width": 640, "height": 480,
//    "pose": [[1,0,0,0], [0,1,0,0], [0,0,1,0], [0,0,0,1]]}
//
// fx, fy, cx, cy in pixels (pixel (0,0) is the centre of the top-left pixel); pose is the row-major 4x4
// camera-to-world matrix as nested lists, in the scene's world frame: the first capture camera's, x right, y down,
// z forward, metres. The camera looks along its own +z with +y down (OpenCV), as the capture cameras do: a camera
// equal to a capture camera renders exactly the capture view.
//
// Used by `rgbdcast render --camera cam.json` and by the view route's camera= query parameter or POST body; input from
// the network, so everything is checked.
#include <string_view>

#include "scene/camera.h"
#include "scene/result.h"

namespace rgbdcast::service {

inline constexpr size_t kMaxCameraJsonBytes = 16 * 1024;
// How far pose's rotation block may be from a rotation (max |R^T R - I| and |det R - 1|): float-printed matrices
// are ~1e-7 off, a scaled or sheared matrix far more.
inline constexpr double kRotationTolerance = 1e-4;

// Parses and validates a camera. Errors are kInvalidArgument, one line (the caller prefixes where the JSON came from):
// not JSON or not an object, over kMaxCameraJsonBytes, a missing or unknown key, a non-number or non-finite value,
// fx or fy <= 0, width or height not an integer in 1..max_size, cx outside [0, width] or cy outside [0, height], pose
// not 4 rows of 4 numbers, a last row other than 0 0 0 1, a rotation block that is not a rotation within
// kRotationTolerance, a translation beyond 1e6 m. The pose is kept exactly as given (not re-orthonormalised).
Result<ViewCamera> parse_camera_json(std::string_view text, int max_size);

// The JSON parse_camera_json reads back to the same camera (numbers printed to round-trip exactly).
std::string camera_json(const ViewCamera& camera);

}  // namespace rgbdcast::service
