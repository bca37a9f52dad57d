#pragma once
// The pixels and camera of ROS messages, decoded without ROS headers: the fields of a sensor_msgs/Image and of a
// sensor_msgs/CameraInfo, as plain values, to OpenCV images and Intrinsics. The bag reader (rosbag_source.cpp) copies
// the message fields in; anything that can come off a network (a streamed message) goes through the same checks.
#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "scene/intrinsics.h"
#include "scene/result.h"

namespace rgbdcast {

// The fields of a sensor_msgs/Image. `data` is the message's buffer (rows of `step` bytes).
struct RosImageView {
  std::string encoding;  // sensor_msgs/image_encodings names: "rgb8", "16UC1", ...
  std::uint32_t width = 0, height = 0, step = 0;
  bool big_endian = false;
  const std::uint8_t* data = nullptr;
  size_t size = 0;
};

// Colour: rgb8, bgr8 or mono8 to an RGB CV_8UC3 image (a copy). Errors (kInvalidInput) name `what`: another
// encoding, a size of 0 or above kMaxImageSize, a step shorter than a row, a buffer shorter than step * height.
Result<cv::Mat> ros_color_to_rgb(const RosImageView& image, const std::string& what);

// Depth as make_frame takes it. 16UC1 (millimetres by ROS convention, REP 118): CV_16UC1 raw values, to be divided
// by the source's depth scale. 32FC1 (metres): CV_32FC1 metres, NaN, infinities and values <= 0 set to 0 (no
// reading). Big-endian buffers are swapped. Errors as ros_color_to_rgb.
struct RosDepth {
  cv::Mat image;
  bool metres = false;  // true for 32FC1: image is already in metres (depth scale 1)
};
Result<RosDepth> ros_depth(const RosImageView& image, const std::string& what);

// The fields of a sensor_msgs/CameraInfo that rgbdcast uses.
struct RosCameraInfo {
  std::uint32_t width = 0, height = 0;
  std::string distortion_model;  // "plumb_bob", "rational_polynomial" or "" (none)
  std::vector<double> D;
  std::array<double, 9> K{};  // row-major 3x3
};
// Pinhole intrinsics with OpenCV-ordered distortion (plumb_bob's D is k1 k2 p1 p2 k3, OpenCV's order). A
// rational_polynomial model is accepted when its k4..k6 are 0. Errors (kInvalidInput): non-finite or non-positive
// focal lengths, a centre outside the image, a size of 0 or above kMaxImageSize, another distortion model (e.g.
// "equidistant"), non-zero terms rgbdcast cannot undistort.
Result<Intrinsics> intrinsics_from_camera_info(const RosCameraInfo& info, const std::string& what);

}  // namespace rgbdcast
