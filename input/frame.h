#pragma once
// One RGB-D frame as the reduction sees it: undistorted colour and metric depth on the same pinhole camera.
#include <opencv2/core.hpp>
#include <string>

#include "scene/intrinsics.h"

namespace rgbdcast {

struct RgbdFrame {
  cv::Mat color_rgb;       // CV_8UC3, RGB order (not OpenCV's BGR), undistorted
  cv::Mat depth_m;         // CV_32FC1, metres along z, 0 where the sensor gave no depth; same size as color_rgb
  cv::Mat xyz_m;           // optional CV_32FC3 organized points (from a PCD), NaN where invalid; overrides depth_m
                           // for back-projection when present
  Intrinsics intrinsics;   // pinhole (distortion already removed from the images)
  double timestamp = 0.0;  // seconds (rgb timestamp for TUM), 0 when unknown
  int index = 0;           // position in its source
  std::string color_path, depth_path;
};

}  // namespace rgbdcast
