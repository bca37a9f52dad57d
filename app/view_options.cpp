#include "app/view_options.h"

#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "base/atomic_file.h"

namespace rgbdcast::app {

void add_backend_options(CLI::App* cmd, ViewArgs* a) {
  cmd->add_option("--backend", a->backend, "auto|vulkan|osmesa")->capture_default_str();
  cmd->add_option("--mode", a->mode, "mesh|points")->capture_default_str();
  cmd->add_option("--point-size", a->point_size_px, "Splat size in pixels (points mode)")->capture_default_str();
}

void add_camera_options(CLI::App* cmd, ViewArgs* a) {
  cmd->add_option("--pose", a->pose, "capture: the robot's own view");
  cmd->add_option("--eye", a->eye, "Camera position x,y,z (world = first capture camera frame, y down)");
  cmd->add_option("--target", a->target, "Point looked at x,y,z");
  cmd->add_option("--up", a->up, "Up direction x,y,z")->capture_default_str();
  cmd->add_option("--fov", a->fov_deg, "Vertical field of view in degrees (above 0.5, at most 179)")
      ->capture_default_str();
  cmd->add_option("--width", a->width, "Image width (default: the capture camera's)");
  cmd->add_option("--height", a->height, "Image height (default: the capture camera's)");
}

Result<RenderOptions> render_options(const ViewArgs& a) {
  RenderOptions o;
  if (a.mode == "mesh")
    o.mode = RenderMode::kMesh;
  else if (a.mode == "points")
    o.mode = RenderMode::kPoints;
  else
    return make_error(ErrorCode::kInvalidArgument, "--mode must be mesh or points");
  if (!(a.point_size_px >= 1.0f && a.point_size_px <= 64.0f))
    return make_error(ErrorCode::kInvalidArgument, "--point-size must be between 1 and 64 pixels");
  o.point_size_px = a.point_size_px;
  return o;
}

static Result<Eigen::Vector3d> parse_vec3(const std::string& text, const char* what) {
  std::stringstream ss(text);
  Eigen::Vector3d v;
  char c1 = 0, c2 = 0;
  if (!(ss >> v.x() >> c1 >> v.y() >> c2 >> v.z()) || c1 != ',' || c2 != ',' || !ss.eof())
    return make_error(ErrorCode::kInvalidArgument, std::string(what) + " must be three numbers x,y,z");
  if (!v.allFinite()) return make_error(ErrorCode::kInvalidArgument, std::string(what) + " must be finite");
  return v;
}

Result<ViewCamera> view_camera(const ViewArgs& a, const Scene& scene) {
  const bool sized = a.width != 0 || a.height != 0;
  if (sized && (a.width < 1 || a.height < 1 || a.width > kMaxImageSize || a.height > kMaxImageSize))
    return make_error(ErrorCode::kInvalidArgument,
                      "--width and --height must be between 1 and " + std::to_string(kMaxImageSize));
  if (a.pose == "capture" || (a.pose.empty() && a.eye.empty())) {
    if (scene.cameras.empty()) return make_error(ErrorCode::kInvalidInput, "the scene has no capture camera");
    const CaptureCamera& cam = scene.cameras.front();
    if (!sized) return ViewCamera::from_capture(cam);
    return ViewCamera::from_capture(cam, a.width, a.height);
  }
  if (!a.pose.empty()) return make_error(ErrorCode::kInvalidArgument, "--pose takes only \"capture\"");
  if (a.target.empty()) return make_error(ErrorCode::kInvalidArgument, "--eye needs --target");
  auto eye = parse_vec3(a.eye, "--eye");
  if (!eye) return eye.error();
  auto target = parse_vec3(a.target, "--target");
  if (!target) return target.error();
  auto up = parse_vec3(a.up, "--up");
  if (!up) return up.error();
  return ViewCamera::look_at(*eye, *target, *up, a.fov_deg, sized ? a.width : 640, sized ? a.height : 480);
}

Result<RendererSelection> make_renderer(const ViewArgs& a) {
  auto choice = parse_backend_choice(a.backend);
  if (!choice) return choice.error();
  return create_renderer(*choice);
}

Status write_image(const Image& image, const std::string& path) {
  cv::Mat src(image.height, image.width, CV_8UC(image.channels), const_cast<std::uint8_t*>(image.data.data()));
  std::string ext = std::filesystem::path(path).extension().string();
  if (ext.empty()) ext = ".png";
  const bool jpeg = ext == ".jpg" || ext == ".jpeg";  // JPEG has no alpha
  cv::Mat bgr;
  if (image.channels == 4)
    cv::cvtColor(src, bgr, jpeg ? cv::COLOR_RGBA2BGR : cv::COLOR_RGBA2BGRA);
  else
    cv::cvtColor(src, bgr, cv::COLOR_RGB2BGR);
  std::vector<unsigned char> bytes;
  try {
    if (!cv::imencode(ext, bgr, bytes)) return make_error(ErrorCode::kInvalidArgument, "cannot encode " + path);
  } catch (const cv::Exception&) {
    return make_error(ErrorCode::kInvalidArgument, "unsupported image type for " + path + " (use .png or .jpg)");
  }
  return write_file_atomically(path, std::vector<std::uint8_t>(bytes.begin(), bytes.end()));
}

}  // namespace rgbdcast::app
