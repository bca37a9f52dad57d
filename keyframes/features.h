#pragma once
// Keypoints and descriptors of one RGB-D frame (paper section 3.1/4): the colour image is converted to grey and
// smoothed with a Gaussian of sigma 0.85 px, then SIFT (default; SURF is not in Debian's OpenCV), ORB (the fast
// option) or AKAZE detect and describe. Keypoints whose pixel has no depth (0, NaN) or sits on a depth edge are
// dropped; each survivor carries its 3D point in the camera frame (x right, y down, z forward, metres).
#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "input/frame.h"
#include "scene/result.h"

namespace rgbdcast {

enum class FeatureType { kSift, kOrb, kAkaze };

const char* to_string(FeatureType type);
// "sift", "orb", "akaze" (case-insensitive); kInvalidArgument otherwise.
Result<FeatureType> parse_feature_type(std::string_view name);
// Float descriptors (SIFT) are matched with a FLANN KD-tree, binary ones (ORB, AKAZE) with FLANN LSH.
bool is_binary_descriptor(FeatureType type);

struct FeatureParams {
  FeatureType type = FeatureType::kSift;
  double smoothing_sigma_px = 0.85;  // paper: Gaussian smoothing before detection; 0 = none
  int max_features = 2000;           // strongest keypoints kept (SIFT/ORB); 0 = detector's own limit
  double max_depth_jump = 0.05;      // drop a keypoint when its 3x3 depth neighbourhood varies by more than this
                                     // fraction of its depth (a depth edge: the 3D point is unreliable); <= 0 = off
  Status validate() const;
};

struct FrameFeatures {
  FeatureType type = FeatureType::kSift;
  std::vector<cv::KeyPoint> keypoints;    // only keypoints with valid depth
  cv::Mat descriptors;                    // one row per keypoint (CV_32F for SIFT, CV_8U for ORB/AKAZE)
  std::vector<Eigen::Vector3d> points_m;  // camera-frame 3D point of each keypoint
  int detected = 0;                       // keypoints found before the depth filter
  size_t size() const { return keypoints.size(); }
};

// Errors: kInvalidInput (colour not 8-bit 3-channel, depth not CV_32F of the same size), kEmpty (no keypoint with
// valid depth; the message says how many the detector found before the depth filter).
Result<FrameFeatures> detect_features(const RgbdFrame& frame, const FeatureParams& params);

}  // namespace rgbdcast
