#include "input/ros_image.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <opencv2/imgproc.hpp>

#include "scene/camera.h"
#include "scene/error_text.h"

namespace rgbdcast {

namespace {

// Checks the size fields against the buffer and returns the image's rows wrapped (no copy) as `type`.
Result<cv::Mat> wrap(const RosImageView& im, int type, const std::string& what) {
  const size_t row_bytes = size_t(im.width) * CV_ELEM_SIZE(type);
  if (im.width == 0 || im.height == 0 || im.width > kMaxImageSize || im.height > kMaxImageSize)
    return make_error(ErrorCode::kInvalidInput, what + ": image size " + std::to_string(im.width) + "x" +
                                                    std::to_string(im.height) + " is outside 1.." +
                                                    std::to_string(kMaxImageSize));
  if (im.step < row_bytes)
    return make_error(ErrorCode::kInvalidInput, what + ": step " + std::to_string(im.step) + " is shorter than a " +
                                                    quote_for_error(im.encoding) + " row of " +
                                                    std::to_string(row_bytes) + " bytes");
  if (im.data == nullptr || im.size < size_t(im.step) * im.height)
    return make_error(ErrorCode::kInvalidInput, what + ": " + std::to_string(im.size) + " bytes of data, " +
                                                    std::to_string(size_t(im.step) * im.height) + " expected");
  return cv::Mat(int(im.height), int(im.width), type, const_cast<std::uint8_t*>(im.data), im.step);
}

bool host_is_big_endian() {
  const std::uint16_t one = 1;
  std::uint8_t first;
  std::memcpy(&first, &one, 1);
  return first == 0;
}

// Swaps each element's bytes in place when the buffer's byte order is not the machine's.
void to_host_order(cv::Mat& m, bool big_endian) {
  if (big_endian == host_is_big_endian()) return;
  const size_t n = m.elemSize1();
  for (int y = 0; y < m.rows; ++y) {
    std::uint8_t* p = m.ptr<std::uint8_t>(y);
    for (int x = 0; x < m.cols; ++x, p += n) std::reverse(p, p + n);
  }
}

}  // namespace

Result<cv::Mat> ros_color_to_rgb(const RosImageView& im, const std::string& what) {
  int type, code;
  if (im.encoding == "rgb8")
    type = CV_8UC3, code = -1;
  else if (im.encoding == "bgr8")
    type = CV_8UC3, code = cv::COLOR_BGR2RGB;
  else if (im.encoding == "mono8")
    type = CV_8UC1, code = cv::COLOR_GRAY2RGB;
  else
    return make_error(ErrorCode::kInvalidInput, what + ": colour encoding \"" + quote_for_error(im.encoding) +
                                                    "\" is not supported (rgb8, bgr8 or mono8)");
  auto m = wrap(im, type, what);
  if (!m) return m;
  cv::Mat rgb;
  if (code < 0)
    rgb = m->clone();
  else
    cv::cvtColor(*m, rgb, code);
  return rgb;
}

Result<RosDepth> ros_depth(const RosImageView& im, const std::string& what) {
  RosDepth d;
  int type;
  if (im.encoding == "16UC1")
    type = CV_16UC1;
  else if (im.encoding == "32FC1")
    type = CV_32FC1, d.metres = true;
  else
    return make_error(ErrorCode::kInvalidInput, what + ": depth encoding \"" + quote_for_error(im.encoding) +
                                                    "\" is not supported (16UC1 in millimetres or 32FC1 in metres)");
  auto m = wrap(im, type, what);
  if (!m) return m.error();
  d.image = m->clone();
  to_host_order(d.image, im.big_endian);
  if (d.metres) {
    // ROS drivers mark missing readings with NaN (or 0); rgbdcast's frames use 0.
    for (int y = 0; y < d.image.rows; ++y) {
      float* row = d.image.ptr<float>(y);
      for (int x = 0; x < d.image.cols; ++x)
        if (!std::isfinite(row[x]) || row[x] <= 0.0f) row[x] = 0.0f;
    }
  }
  return d;
}

Result<Intrinsics> intrinsics_from_camera_info(const RosCameraInfo& info, const std::string& what) {
  auto bad = [&](const std::string& why) { return make_error(ErrorCode::kInvalidInput, what + ": " + why); };
  if (info.width == 0 || info.height == 0 || info.width > kMaxImageSize || info.height > kMaxImageSize)
    return bad("camera size " + std::to_string(info.width) + "x" + std::to_string(info.height) + " is outside 1.." +
               std::to_string(kMaxImageSize));
  for (double v : info.K)
    if (!std::isfinite(v)) return bad("K holds a non-finite value");
  for (double v : info.D)
    if (!std::isfinite(v)) return bad("D holds a non-finite value");
  const auto& K = info.K;
  if (!(K[0] > 0) || !(K[4] > 0)) return bad("focal lengths in K must be positive");
  if (K[1] != 0 || K[3] != 0 || K[6] != 0 || K[7] != 0 || K[8] != 1)
    return bad("K is not a pinhole matrix (skew or bad last row)");
  if (K[2] < 0 || K[2] > info.width || K[5] < 0 || K[5] > info.height) return bad("principal point outside the image");
  Intrinsics k;
  k.fx = K[0];
  k.fy = K[4];
  k.cx = K[2];
  k.cy = K[5];
  k.width = int(info.width);
  k.height = int(info.height);
  k.name = "camera_info";
  k.distortion = {};
  const bool any = [&] {
    for (double v : info.D)
      if (v != 0) return true;
    return false;
  }();
  if (!any) return k;
  if (info.distortion_model != "plumb_bob" && info.distortion_model != "rational_polynomial")
    return bad("distortion model \"" + quote_for_error(info.distortion_model) +
               "\" is not supported (plumb_bob or rational_polynomial)");
  for (size_t i = 5; i < info.D.size(); ++i)
    if (info.D[i] != 0) return bad("distortion terms past k1 k2 p1 p2 k3 are not supported");
  for (size_t i = 0; i < 5 && i < info.D.size(); ++i) k.distortion[i] = info.D[i];
  return k;
}

}  // namespace rgbdcast
