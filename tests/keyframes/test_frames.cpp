#include "tests/keyframes/test_frames.h"

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "tests/common/test_data.h"

namespace rgbdcast::test {

Result<RgbdFrame> load_rgbd(const FramePaths& paths, const Intrinsics& k, int index) {
  cv::Mat bgr = cv::imread(paths.color, cv::IMREAD_COLOR);
  if (bgr.empty()) return make_error(ErrorCode::kNotFound, "cannot read colour image " + paths.color);
  cv::Mat raw = cv::imread(paths.depth, cv::IMREAD_UNCHANGED);
  if (raw.empty()) return make_error(ErrorCode::kNotFound, "cannot read depth image " + paths.depth);
  if (raw.type() != CV_16UC1) return make_error(ErrorCode::kInvalidInput, "depth is not 16-bit: " + paths.depth);
  if (raw.size() != bgr.size()) return make_error(ErrorCode::kInvalidInput, "colour and depth sizes differ");
  RgbdFrame f;
  cv::cvtColor(bgr, f.color_rgb, cv::COLOR_BGR2RGB);
  raw.convertTo(f.depth_m, CV_32F, 1.0 / k.depth_scale);
  if (k.has_distortion()) {
    const cv::Mat kk = (cv::Mat_<double>(3, 3) << k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
    const cv::Mat dist(1, 5, CV_64F, const_cast<double*>(k.distortion.data()));
    cv::Mat map1, map2;
    cv::initUndistortRectifyMap(kk, dist, cv::Mat(), kk, f.color_rgb.size(), CV_32FC1, map1, map2);
    cv::Mat c, d;
    cv::remap(f.color_rgb, c, map1, map2, cv::INTER_LINEAR);
    cv::remap(f.depth_m, d, map1, map2, cv::INTER_NEAREST);  // never blend depths across edges
    f.color_rgb = c;
    f.depth_m = d;
  }
  f.intrinsics = k.pinhole();
  f.timestamp = paths.timestamp;
  f.index = index;
  f.color_path = paths.color;
  f.depth_path = paths.depth;
  return f;
}

FrameLoader TestSequence::loader() const {
  return [this](size_t i) -> Result<RgbdFrame> {
    if (i >= frames.size()) return make_error(ErrorCode::kNotFound, "frame " + std::to_string(i) + " past the end");
    return load_rgbd(frames[i], intrinsics, static_cast<int>(i));
  };
}

TestSequence augmented_icl_sequence() {
  TestSequence s;
  s.name = "augmented_icl_livingroom";
  std::ifstream in(data_path("augmented_icl_livingroom/camera_primesense.json"));
  const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  if (!j.is_discarded()) {
    const auto& m = j["intrinsic_matrix"];  // column-major 3x3
    s.intrinsics.width = j["width"];
    s.intrinsics.height = j["height"];
    s.intrinsics.fx = m[0];
    s.intrinsics.fy = m[4];
    s.intrinsics.cx = m[6];
    s.intrinsics.cy = m[7];
  }
  s.intrinsics.depth_scale = 1000.0;
  s.intrinsics.name = "primesense";
  for (int i = 0; i < 5; ++i) {
    char name[16];
    std::snprintf(name, sizeof name, "%05d", i);
    s.frames.push_back({data_path(std::string("augmented_icl_livingroom/color/") + name + ".jpg"),
                        data_path(std::string("augmented_icl_livingroom/depth/") + name + ".png"), 0.0});
  }
  return s;
}

TestSequence icl_nuim_sequence() {
  TestSequence s;
  s.name = "icl_nuim_livingroom";
  s.intrinsics.fx = 481.2;
  s.intrinsics.fy = 480.0;  // ICL: -480 with a y-up camera; +480 is the same image in rgbdcast's y-down camera
  s.intrinsics.cx = 319.5;
  s.intrinsics.cy = 239.5;
  s.intrinsics.depth_scale = 5000.0;
  s.intrinsics.name = "icl_nuim";
  for (int i = 1; i <= 5; ++i)
    s.frames.push_back({data_path("icl_nuim_livingroom/color/" + std::to_string(i) + ".png"),
                        data_path("icl_nuim_livingroom/depth/" + std::to_string(i) + ".png"), 0.0});
  return s;
}

namespace {
std::vector<std::pair<double, std::string>> read_list(const std::string& path) {
  std::vector<std::pair<double, std::string>> out;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    double t;
    std::string p;
    if (ss >> t >> p) out.emplace_back(t, p);
  }
  return out;
}
}  // namespace

TestSequence tum_fr1_xyz_sequence() {
  TestSequence s;
  s.name = "tum_fr1_xyz";
  s.intrinsics.fx = 517.3;
  s.intrinsics.fy = 516.5;
  s.intrinsics.cx = 318.6;
  s.intrinsics.cy = 255.3;
  s.intrinsics.distortion = {0.2624, -0.9531, -0.0054, 0.0026, 1.1633};
  s.intrinsics.depth_scale = 5000.0;
  s.intrinsics.name = "fr1";
  const std::string root = data_path("tum/rgbd_dataset_freiburg1_xyz/");
  const auto rgb = read_list(root + "rgb.txt");
  const auto depth = read_list(root + "depth.txt");
  // The three depth maps pair with the nearest rgb stamps (all within 20 ms).
  for (const auto& [td, pd] : depth) {
    double best = 1e9;
    std::string best_rgb;
    double best_t = 0;
    for (const auto& [tr, pr] : rgb)
      if (std::abs(tr - td) < best) {
        best = std::abs(tr - td);
        best_rgb = pr;
        best_t = tr;
      }
    if (best < 0.02) s.frames.push_back({root + best_rgb, root + pd, best_t});
  }
  return s;
}

}  // namespace rgbdcast::test
