#include "keyframes/features.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

namespace rgbdcast {

const char* to_string(FeatureType type) {
  switch (type) {
    case FeatureType::kSift:
      return "sift";
    case FeatureType::kOrb:
      return "orb";
    case FeatureType::kAkaze:
      return "akaze";
  }
  return "?";
}

Result<FeatureType> parse_feature_type(std::string_view name) {
  std::string n(name);
  std::transform(n.begin(), n.end(), n.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (n == "sift") return FeatureType::kSift;
  if (n == "orb") return FeatureType::kOrb;
  if (n == "akaze") return FeatureType::kAkaze;
  return make_error(ErrorCode::kInvalidArgument, "unknown feature type '" + std::string(name) + "' (sift, orb, akaze)");
}

bool is_binary_descriptor(FeatureType type) { return type != FeatureType::kSift; }

Status FeatureParams::validate() const {
  if (!std::isfinite(smoothing_sigma_px) || smoothing_sigma_px < 0 || smoothing_sigma_px > 20)
    return make_error(ErrorCode::kInvalidArgument, "smoothing sigma must be in [0, 20] px");
  if (max_features < 0) return make_error(ErrorCode::kInvalidArgument, "max_features must be >= 0");
  if (!std::isfinite(max_depth_jump)) return make_error(ErrorCode::kInvalidArgument, "max_depth_jump must be finite");
  return ok_status();
}

namespace {

cv::Ptr<cv::Feature2D> make_detector(const FeatureParams& p) {
  switch (p.type) {
    case FeatureType::kSift:
      return cv::SIFT::create(p.max_features);
    case FeatureType::kOrb:
      return cv::ORB::create(p.max_features > 0 ? p.max_features : 500);
    case FeatureType::kAkaze:
      return cv::AKAZE::create();
  }
  return {};
}

// The camera-frame point under pixel (u, v), or NaN when there is no reliable depth there.
Eigen::Vector3d point_at(const RgbdFrame& f, int u, int v, double max_jump) {
  const Eigen::Vector3d none = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  if (!f.xyz_m.empty()) {
    const cv::Vec3f p = f.xyz_m.at<cv::Vec3f>(v, u);
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]) || p[2] <= 0) return none;
    return {p[0], p[1], p[2]};
  }
  const float z = f.depth_m.at<float>(v, u);
  if (!std::isfinite(z) || z <= 0.f) return none;
  if (max_jump > 0) {
    for (int dv = -1; dv <= 1; ++dv)
      for (int du = -1; du <= 1; ++du) {
        const int x = std::clamp(u + du, 0, f.depth_m.cols - 1), y = std::clamp(v + dv, 0, f.depth_m.rows - 1);
        const float zn = f.depth_m.at<float>(y, x);
        if (!std::isfinite(zn) || zn <= 0.f || std::abs(zn - z) > max_jump * z) return none;
      }
  }
  return f.intrinsics.backproject(u, v, z);
}

}  // namespace

Result<FrameFeatures> detect_features(const RgbdFrame& frame, const FeatureParams& params) {
  if (Status s = params.validate(); !s) return s.error();
  if (frame.color_rgb.empty() || frame.color_rgb.type() != CV_8UC3)
    return make_error(ErrorCode::kInvalidInput, "frame " + std::to_string(frame.index) + ": colour must be 8-bit RGB");
  const bool have_xyz = !frame.xyz_m.empty();
  const cv::Mat& geo = have_xyz ? frame.xyz_m : frame.depth_m;
  if (geo.size() != frame.color_rgb.size() || (have_xyz ? geo.type() != CV_32FC3 : geo.type() != CV_32FC1))
    return make_error(ErrorCode::kInvalidInput,
                      "frame " + std::to_string(frame.index) + ": depth must be CV_32F metres of the colour's size");

  cv::Mat grey;
  cv::cvtColor(frame.color_rgb, grey, cv::COLOR_RGB2GRAY);
  if (params.smoothing_sigma_px > 0) cv::GaussianBlur(grey, grey, cv::Size(0, 0), params.smoothing_sigma_px);

  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  make_detector(params)->detectAndCompute(grey, cv::noArray(), keypoints, descriptors);

  FrameFeatures out;
  out.type = params.type;
  out.detected = static_cast<int>(keypoints.size());
  std::vector<int> keep;
  keep.reserve(keypoints.size());
  for (size_t i = 0; i < keypoints.size(); ++i) {
    const int u = std::clamp(static_cast<int>(std::lround(keypoints[i].pt.x)), 0, grey.cols - 1);
    const int v = std::clamp(static_cast<int>(std::lround(keypoints[i].pt.y)), 0, grey.rows - 1);
    const Eigen::Vector3d p = point_at(frame, u, v, params.max_depth_jump);
    if (!p.allFinite()) continue;
    keep.push_back(static_cast<int>(i));
    out.keypoints.push_back(keypoints[i]);
    out.points_m.push_back(p);
  }
  if (keep.empty())
    return make_error(ErrorCode::kEmpty, "frame " + std::to_string(frame.index) + ": no " + to_string(params.type) +
                                             " keypoint with depth (" + std::to_string(out.detected) +
                                             " detected before the depth filter)");
  out.descriptors.create(static_cast<int>(keep.size()), descriptors.cols, descriptors.type());
  for (size_t r = 0; r < keep.size(); ++r) descriptors.row(keep[r]).copyTo(out.descriptors.row(static_cast<int>(r)));
  return out;
}

}  // namespace rgbdcast
