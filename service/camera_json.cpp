#include "service/camera_json.h"

#include <cmath>
#include <nlohmann/json.hpp>

#include "service/http_errors.h"

namespace rgbdcast::service {

namespace {

Error bad(const std::string& what) { return make_error(ErrorCode::kInvalidArgument, what); }

Result<double> finite_number(const nlohmann::json& j, const std::string& name) {
  if (!j.is_number()) return bad("'" + name + "' must be a number");
  const double v = j.get<double>();
  if (!std::isfinite(v)) return bad("'" + name + "' must be finite");
  return v;
}

Result<int> size_value(const nlohmann::json& j, const std::string& name, int max_size) {
  if (!j.is_number_integer()) return bad("'" + name + "' must be an integer");
  const long long v = j.get<long long>();
  if (v < 1 || v > max_size) return bad("'" + name + "' must be 1.." + std::to_string(max_size));
  return static_cast<int>(v);
}

Result<Eigen::Matrix4d> pose_value(const nlohmann::json& j) {
  const char* shape = "'pose' must be 4 rows of 4 numbers (row-major camera-to-world)";
  if (!j.is_array() || j.size() != 4) return bad(shape);
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r) {
    if (!j[r].is_array() || j[r].size() != 4) return bad(shape);
    for (int c = 0; c < 4; ++c) {
      auto v = finite_number(j[r][c], "pose[" + std::to_string(r) + "][" + std::to_string(c) + "]");
      if (!v) return v.error();
      m(r, c) = *v;
    }
  }
  if (m(3, 0) != 0 || m(3, 1) != 0 || m(3, 2) != 0 || m(3, 3) != 1) return bad("'pose' last row must be 0 0 0 1");
  const Eigen::Matrix3d R = m.topLeftCorner<3, 3>();
  const double orthogonality = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (orthogonality > kRotationTolerance || std::abs(R.determinant() - 1.0) > kRotationTolerance)
    return bad("'pose' rotation is not a rotation (orthonormal, determinant 1) within 1e-4");
  if (m.topRightCorner<3, 1>().cwiseAbs().maxCoeff() > 1e6) return bad("'pose' translation beyond 1e6 m");
  return m;
}

}  // namespace

Result<ViewCamera> parse_camera_json(std::string_view text, int max_size) {
  if (text.size() > kMaxCameraJsonBytes) return bad("JSON over " + std::to_string(kMaxCameraJsonBytes) + " bytes");
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return bad("not valid JSON");
  if (!j.is_object()) return bad("must be a JSON object {fx, fy, cx, cy, width, height, pose}");
  static const char* kKeys[] = {"fx", "fy", "cx", "cy", "width", "height", "pose"};
  for (const char* k : kKeys)
    if (!j.contains(k)) return bad(std::string("missing '") + k + "'");
  for (const auto& [key, value] : j.items()) {
    bool known = false;
    for (const char* k : kKeys) known = known || key == k;
    if (!known) return bad("unknown key '" + quote_for_error(key, 40) + "'");
  }
  ViewCamera cam;
  auto width = size_value(j["width"], "width", max_size);
  if (!width) return width.error();
  auto height = size_value(j["height"], "height", max_size);
  if (!height) return height.error();
  cam.width = *width;
  cam.height = *height;
  double* fields[] = {&cam.fx, &cam.fy, &cam.cx, &cam.cy};
  for (int i = 0; i < 4; ++i) {
    auto v = finite_number(j[kKeys[i]], kKeys[i]);
    if (!v) return v.error();
    *fields[i] = *v;
  }
  if (!(cam.fx > 0) || !(cam.fy > 0)) return bad("'fx' and 'fy' must be positive");
  if (cam.cx < 0 || cam.cx > cam.width) return bad("'cx' must be within 0..width");
  if (cam.cy < 0 || cam.cy > cam.height) return bad("'cy' must be within 0..height");
  auto pose = pose_value(j["pose"]);
  if (!pose) return pose.error();
  cam.camera_to_world = *pose;
  return cam;
}

std::string camera_json(const ViewCamera& c) {
  nlohmann::json pose = nlohmann::json::array();
  for (int r = 0; r < 4; ++r)
    pose.push_back(
        {c.camera_to_world(r, 0), c.camera_to_world(r, 1), c.camera_to_world(r, 2), c.camera_to_world(r, 3)});
  return nlohmann::json{{"fx", c.fx},       {"fy", c.fy},         {"cx", c.cx},  {"cy", c.cy},
                        {"width", c.width}, {"height", c.height}, {"pose", pose}}
      .dump();
}

}  // namespace rgbdcast::service
