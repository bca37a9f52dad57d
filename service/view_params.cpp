#include "service/view_params.h"

#include <charconv>
#include <cmath>
#include <set>

#include "service/camera_json.h"
#include "service/http_errors.h"

namespace rgbdcast::service {
namespace {

Error bad(const std::string& name, const std::string& what) {
  return make_error(ErrorCode::kInvalidArgument, "parameter '" + name + "': " + what);
}

std::string shorten(const std::string& s) { return quote_for_error(s, 40); }

}  // namespace

const char* to_string(ImageFormat format) { return format == ImageFormat::kJpeg ? "jpeg" : "png"; }
const char* mime_type(ImageFormat format) { return format == ImageFormat::kJpeg ? "image/jpeg" : "image/png"; }

Result<double> parse_finite_double(const std::string& name, const std::string& text) {
  if (text.empty()) return bad(name, "empty value");
  double v = 0.0;
  const char* end = text.data() + text.size();
  auto [p, ec] = std::from_chars(text.data(), end, v, std::chars_format::general);
  if (ec != std::errc() || p != end) return bad(name, single_quoted_for_error(text) + " is not a number");
  if (!std::isfinite(v)) return bad(name, single_quoted_for_error(text) + " is not a finite number");
  return v;
}

Result<int> parse_int_in_range(const std::string& name, const std::string& text, int lo, int hi) {
  if (text.empty()) return bad(name, "empty value");
  long long v = 0;
  const char* end = text.data() + text.size();
  auto [p, ec] = std::from_chars(text.data(), end, v);
  if (ec == std::errc::result_out_of_range)
    return bad(name, "out of range " + std::to_string(lo) + ".." + std::to_string(hi));
  if (ec != std::errc() || p != end) return bad(name, single_quoted_for_error(text) + " is not an integer");
  if (v < lo || v > hi)
    return bad(name, std::to_string(v) + " is outside " + std::to_string(lo) + ".." + std::to_string(hi));
  return static_cast<int>(v);
}

Result<Eigen::Vector3d> parse_vec3(const std::string& name, const std::string& text) {
  Eigen::Vector3d v;
  size_t start = 0;
  for (int i = 0; i < 3; ++i) {
    const size_t comma = text.find(',', start);
    if ((i < 2) != (comma != std::string::npos))
      return bad(name, "expected three comma-separated numbers x,y,z, got '" + shorten(text) + "'");
    const std::string part = text.substr(start, i < 2 ? comma - start : std::string::npos);
    auto d = parse_finite_double(name, part);
    if (!d) return d.error();
    v[i] = *d;
    start = comma + 1;
  }
  return v;
}

Result<ViewRequest> parse_view_request(const QueryParams& params) {
  static const std::set<std::string> kKnown = {"pose",   "eye",  "target", "up",      "fov",        "width",
                                               "height", "mode", "format", "quality", "point_size", "camera"};
  std::map<std::string, std::string> one;
  for (const auto& [name, value] : params) {
    if (!kKnown.count(name)) return bad(shorten(name), "unknown parameter");
    if (!one.emplace(name, value).second) return bad(name, "given more than once");
  }
  auto has = [&](const char* n) { return one.count(n) > 0; };
  ViewRequest r;

  if (has("camera")) {
    for (const char* other : {"pose", "eye", "target", "up", "fov", "width", "height"})
      if (has(other)) return bad("camera", std::string("a full camera excludes ") + other);
    auto camera = parse_camera_json(one["camera"], kMaxViewSize);
    if (!camera) return bad("camera", camera.error().message);
    r.full_camera = true;
    r.camera = *camera;
    r.capture_pose = false;
    r.width = camera->width;
    r.height = camera->height;
  } else if (has("pose")) {
    if (one["pose"] != "capture") return bad("pose", "only 'capture' is known; use eye and target for other views");
    if (has("eye") || has("target") || has("up") || has("fov"))
      return bad("pose", "pose=capture excludes eye, target, up and fov");
    r.capture_pose = true;
  } else if (has("eye") || has("target")) {
    if (!has("eye")) return bad("eye", "missing (target needs an eye)");
    if (!has("target")) return bad("target", "missing (eye needs a target)");
    r.capture_pose = false;
    auto eye = parse_vec3("eye", one["eye"]);
    if (!eye) return eye.error();
    auto target = parse_vec3("target", one["target"]);
    if (!target) return target.error();
    r.eye = *eye;
    r.target = *target;
    if (has("up")) {
      auto up = parse_vec3("up", one["up"]);
      if (!up) return up.error();
      if (up->norm() < 1e-9) return bad("up", "zero vector");
      r.up = *up;
    }
    if (has("fov")) {
      auto fov = parse_finite_double("fov", one["fov"]);
      if (!fov) return fov.error();
      if (!(*fov >= 1.0 && *fov <= kMaxFovDeg)) return bad("fov", "must be between 1 and 179 degrees");
      r.fov_deg = *fov;
    }
    if ((r.target - r.eye).norm() < 1e-9) return bad("target", "equals eye");
  } else {
    if (has("up") || has("fov")) return bad(has("up") ? "up" : "fov", "needs eye and target");
    return make_error(ErrorCode::kInvalidArgument, "missing the pose: give pose=capture or eye=x,y,z&target=x,y,z");
  }

  if (has("width")) {
    auto w = parse_int_in_range("width", one["width"], 1, kMaxViewSize);
    if (!w) return w.error();
    r.width = *w;
  }
  if (has("height")) {
    auto h = parse_int_in_range("height", one["height"], 1, kMaxViewSize);
    if (!h) return h.error();
    r.height = *h;
  }
  if (has("mode")) {
    const std::string& m = one["mode"];
    if (m == "mesh")
      r.mode = RenderMode::kMesh;
    else if (m == "points")
      r.mode = RenderMode::kPoints;
    else
      return bad("mode", single_quoted_for_error(m) + " is neither mesh nor points");
  }
  if (has("format")) {
    const std::string& f = one["format"];
    if (f == "jpeg" || f == "jpg")
      r.format = ImageFormat::kJpeg;
    else if (f == "png")
      r.format = ImageFormat::kPng;
    else
      return bad("format", single_quoted_for_error(f) + " is neither jpeg nor png");
  }
  if (has("quality")) {
    auto q = parse_int_in_range("quality", one["quality"], 1, 100);
    if (!q) return q.error();
    r.quality = *q;
  }
  if (has("point_size")) {
    auto ps = parse_finite_double("point_size", one["point_size"]);
    if (!ps) return ps.error();
    if (!(*ps >= 1.0 && *ps <= 64.0)) return bad("point_size", "must be between 1 and 64 pixels");
    r.point_size_px = static_cast<float>(*ps);
  }
  return r;
}

Result<ViewCamera> make_view_camera(const ViewRequest& request, const std::vector<CaptureCamera>& cameras) {
  if (request.full_camera) return request.camera;
  if (request.capture_pose) {
    const CaptureCamera cam = cameras.empty() ? CaptureCamera{} : cameras.front();
    if (cam.intrinsics.width < 1 || cam.intrinsics.height < 1)
      return make_error(ErrorCode::kInvalidInput, "the scene's capture camera has no image size");
    return ViewCamera::from_capture(cam, request.width, request.height);
  }
  return ViewCamera::look_at(request.eye, request.target, request.up, request.fov_deg, request.width, request.height);
}

}  // namespace rgbdcast::service
