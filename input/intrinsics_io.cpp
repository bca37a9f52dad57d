#include "input/intrinsics_io.h"

#include <cmath>
#include <cstdint>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

#include "scene/json_nesting.h"

namespace rgbdcast {

std::optional<Intrinsics> intrinsics_preset(const std::string& name) {
  // TUM RGB-D calibration (https://cvg.cit.tum.de/data/datasets/rgbd-dataset/file_formats), OpenCV order d0..d4.
  Intrinsics k;
  k.depth_scale = 5000.0;
  k.name = name;
  if (name == "fr1") {
    k.fx = 517.3;
    k.fy = 516.5;
    k.cx = 318.6;
    k.cy = 255.3;
    k.distortion = {0.2624, -0.9531, -0.0054, 0.0026, 1.1633};
  } else if (name == "fr2") {
    k.fx = 520.9;
    k.fy = 521.0;
    k.cx = 325.1;
    k.cy = 249.7;
    k.distortion = {0.2312, -0.7849, -0.0033, -0.0001, 0.9172};
  } else if (name == "fr3") {
    k.fx = 535.4;
    k.fy = 539.2;
    k.cx = 320.1;
    k.cy = 247.6;  // fr3 images are already undistorted
  } else if (name == "icl") {
    // ICL-NUIM publishes fy = -480 (its camera frame has y up). rgbdcast keeps the right-handed y-down frame with
    // fy = +480; ICL poses convert by conjugation with diag(1, -1, 1).
    k.fx = 481.2;
    k.fy = 480.0;
    k.cx = 319.5;
    k.cy = 239.5;
  } else if (name == "kinect") {
    k.fx = 525.0;
    k.fy = 525.0;
    k.cx = 319.5;
    k.cy = 239.5;
  } else {
    return std::nullopt;
  }
  return k;
}

static Result<Intrinsics> parse_intrinsics(const nlohmann::json& j, const std::string& path) {
  Intrinsics k;
  k.name = path;
  if (!j.is_object()) return make_error(ErrorCode::kInvalidInput, path + ": not a JSON object");
  k.depth_scale = 1000.0;
  auto num = [&](const char* key, double* out) {
    if (j.contains(key)) {
      if (!j[key].is_number()) return false;
      *out = j[key].get<double>();
    }
    return true;
  };
  if (j.contains("intrinsic_matrix")) {  // Open3D PinholeCameraIntrinsic: column-major 3x3
    const auto& m = j["intrinsic_matrix"];
    if (!m.is_array() || m.size() != 9)
      return make_error(ErrorCode::kInvalidInput, path + ": intrinsic_matrix must hold 9 numbers");
    for (const auto& v : m)
      if (!v.is_number()) return make_error(ErrorCode::kInvalidInput, path + ": intrinsic_matrix must hold numbers");
    k.fx = m[0].get<double>();
    k.fy = m[4].get<double>();
    k.cx = m[6].get<double>();
    k.cy = m[7].get<double>();
  } else {
    for (const char* key : {"fx", "fy", "cx", "cy"})
      if (!j.contains(key)) return make_error(ErrorCode::kInvalidInput, path + ": missing \"" + key + "\"");
    if (!num("fx", &k.fx) || !num("fy", &k.fy) || !num("cx", &k.cx) || !num("cy", &k.cy))
      return make_error(ErrorCode::kInvalidInput, path + ": fx, fy, cx, cy must be numbers");
  }
  if (!j.contains("width") || !j.contains("height") || !j["width"].is_number_integer() ||
      !j["height"].is_number_integer())
    return make_error(ErrorCode::kInvalidInput, path + ": width and height must be integers");
  const std::int64_t w = j["width"].get<std::int64_t>(), h = j["height"].get<std::int64_t>();
  if (w < 1 || h < 1 || w > 16384 || h > 16384)
    return make_error(ErrorCode::kInvalidInput, path + ": width and height must be between 1 and 16384");
  k.width = static_cast<int>(w);
  k.height = static_cast<int>(h);
  if (!num("depth_scale", &k.depth_scale))
    return make_error(ErrorCode::kInvalidInput, path + ": depth_scale must be a number");
  if (j.contains("distortion")) {
    const auto& d = j["distortion"];
    if (!d.is_array() || d.size() > 5)
      return make_error(ErrorCode::kInvalidInput, path + ": distortion must be a list of up to 5 numbers");
    for (size_t i = 0; i < d.size(); ++i) {
      if (!d[i].is_number()) return make_error(ErrorCode::kInvalidInput, path + ": distortion must hold numbers");
      k.distortion[i] = d[i].get<double>();
    }
  }
  // Negative focal lengths (ICL-NUIM publishes fy < 0 for its y-up camera) are refused here, not after a reduction:
  // rgbdcast's camera is y-down with fx, fy > 0 (the "icl" preset converts).
  if (!(std::isfinite(k.fx) && std::isfinite(k.fy) && std::isfinite(k.cx) && std::isfinite(k.cy)) || !(k.fx > 0) ||
      !(k.fy > 0))
    return make_error(ErrorCode::kInvalidInput, path + ": focal lengths must be finite and positive");
  if (k.width < 1 || k.height < 1 || k.width > 16384 || k.height > 16384)
    return make_error(ErrorCode::kInvalidInput, path + ": width and height must be between 1 and 16384");
  if (!(std::isfinite(k.depth_scale) && k.depth_scale > 0))
    return make_error(ErrorCode::kInvalidInput, path + ": depth_scale must be positive");
  return k;
}

Result<Intrinsics> parse_intrinsics_json(std::string_view text, const std::string& what) {
  if (auto st = check_json_nesting(text, kMaxIntrinsicsJsonBytes, 16, what); !st) return st.error();
  nlohmann::json j = nlohmann::json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) return make_error(ErrorCode::kInvalidInput, what + ": not a JSON object");
  try {
    return parse_intrinsics(j, what);
  } catch (const nlohmann::json::exception&) {  // get<int> of a number out of int's range, and the like
    return make_error(ErrorCode::kInvalidInput, what + ": a number is out of range");
  }
}

Result<Intrinsics> parse_intrinsics_matrix_text(std::string_view text, const std::string& what) {
  if (text.size() > kMaxIntrinsicsTextBytes)
    return make_error(ErrorCode::kInvalidInput,
                      what + ": a 3x3 matrix file is at most " + std::to_string(kMaxIntrinsicsTextBytes) + " bytes");
  std::istringstream in{std::string(text)};
  std::vector<double> m;
  std::string token;
  while (in >> token) {
    char* end = nullptr;
    const double v = std::strtod(token.c_str(), &end);
    if (end != token.c_str() + token.size() || !std::isfinite(v))
      return make_error(ErrorCode::kInvalidInput, what + ": \"" + token.substr(0, 32) + "\" is not a finite number");
    m.push_back(v);
  }
  if (m.size() != 9)
    return make_error(ErrorCode::kInvalidInput,
                      what + ": a 3x3 camera matrix has 9 numbers, this has " + std::to_string(m.size()));
  if (m[1] != 0 || m[3] != 0 || m[6] != 0 || m[7] != 0 || m[8] != 1)
    return make_error(ErrorCode::kInvalidInput, what + ": not a pinhole camera matrix \"fx 0 cx / 0 fy cy / 0 0 1\"");
  if (!(m[0] > 0) || !(m[4] > 0))
    return make_error(ErrorCode::kInvalidInput, what + ": focal lengths must be finite and positive");
  Intrinsics k;
  k.name = what;
  k.fx = m[0];
  k.cx = m[2];
  k.fy = m[4];
  k.cy = m[5];
  k.width = k.height = 0;  // from the images
  k.depth_scale = 1000.0;
  return k;
}

// The text of an intrinsics file, read up to one byte past `limit` (the parse names the limit).
static Result<std::string> read_intrinsics_file(const std::string& path, size_t limit) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return make_error(ErrorCode::kNotFound, "cannot open intrinsics file " + path);
  std::string text;
  char buf[4096];
  while (in.read(buf, sizeof buf) || in.gcount() > 0) {
    text.append(buf, static_cast<size_t>(in.gcount()));
    if (text.size() > limit) break;
  }
  return text;
}

Result<Intrinsics> load_intrinsics_json(const std::string& path) {
  auto text = read_intrinsics_file(path, kMaxIntrinsicsJsonBytes);
  if (!text) return text.error();
  return parse_intrinsics_json(*text, path);
}

Result<Intrinsics> resolve_intrinsics(const std::string& spec) {
  if (auto preset = intrinsics_preset(spec)) return *preset;
  if (spec.size() > 5 && spec.substr(spec.size() - 5) == ".json") return load_intrinsics_json(spec);
  if (spec.size() > 4 && spec.substr(spec.size() - 4) == ".txt") {
    auto text = read_intrinsics_file(spec, kMaxIntrinsicsTextBytes);
    if (!text) return text.error();
    return parse_intrinsics_matrix_text(*text, spec);
  }
  return make_error(
      ErrorCode::kInvalidArgument,
      "unknown intrinsics \"" + spec + "\" (use fr1, fr2, fr3, kinect, icl, a .json or a 3x3 matrix .txt file)");
}

}  // namespace rgbdcast
