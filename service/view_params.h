#pragma once
// The query of GET /v1/scenes/{id}/view, parsed and validated before anything is rendered. Contract: every parameter
// at most once, no unknown names, numbers finite (NaN and inf are errors), the pose either pose=capture or
// eye+target (up and fov only with eye); any violation is a kInvalidArgument naming the parameter (HTTP 400).
#include <Eigen/Core>
#include <map>
#include <string>
#include <vector>

#include "renderer/renderer.h"
#include "scene/camera.h"
#include "scene/result.h"

namespace rgbdcast::service {

inline constexpr int kMaxViewSize = 4096;  // the service's limit per image side (the renderer allows more)
inline constexpr double kMaxFovDeg = kMaxVerticalFovDeg;  // 179, as ViewCamera::look_at (scene/camera.h)

enum class ImageFormat { kJpeg, kPng };
const char* to_string(ImageFormat format);
const char* mime_type(ImageFormat format);

struct ViewRequest {
  bool capture_pose = true;  // pose=capture: the first capture camera, intrinsics scaled to the size
  Eigen::Vector3d eye{0, 0, 0}, target{0, 0, 1};
  Eigen::Vector3d up{0, -1, 0};  // world up in the camera convention (y down)
  double fov_deg = 49.0;         // vertical; about a Kinect's
  int width = 640, height = 480;
  RenderMode mode = RenderMode::kMesh;
  ImageFormat format = ImageFormat::kJpeg;
  int quality = 85;            // JPEG quality 1..100 (ignored for PNG)
  float point_size_px = 2.0f;  // points mode splat size 1..64
  bool full_camera = false;    // camera=JSON (service/camera_json.h): replaces pose and size
  ViewCamera camera;
};

// Query parameters as the HTTP library gives them (name -> value, a name may repeat).
using QueryParams = std::multimap<std::string, std::string>;

Result<ViewRequest> parse_view_request(const QueryParams& params);

// The camera for a request: the capture camera (or the default Kinect camera at the origin when the scene has none)
// for pose=capture, else a look-at camera. Errors are kInvalidArgument (eye == target, up parallel to the view).
Result<ViewCamera> make_view_camera(const ViewRequest& request, const std::vector<CaptureCamera>& cameras);

// Strict number parsing used above (exposed for tests): the whole string, finite, no leading '+' or spaces.
Result<double> parse_finite_double(const std::string& name, const std::string& text);
Result<int> parse_int_in_range(const std::string& name, const std::string& text, int lo, int hi);
Result<Eigen::Vector3d> parse_vec3(const std::string& name, const std::string& text);

}  // namespace rgbdcast::service
