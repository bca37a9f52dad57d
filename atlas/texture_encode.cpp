#include "atlas/texture_encode.h"

#include <chrono>

#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace rgbdcast {

Result<std::vector<std::uint8_t>> encode_jpeg(const Image& rgb, int quality) {
  if (rgb.empty() || rgb.channels != 3) return make_error(ErrorCode::kInvalidArgument, "JPEG needs an RGB8 image");
  if (quality < 1 || quality > 100)
    return make_error(ErrorCode::kInvalidArgument, "JPEG quality must be 1..100, got " + std::to_string(quality));
  const cv::Mat view(rgb.height, rgb.width, CV_8UC3, const_cast<std::uint8_t*>(rgb.data.data()));
  cv::Mat bgr;
  cv::cvtColor(view, bgr, cv::COLOR_RGB2BGR);
  std::vector<std::uint8_t> out;
  if (!cv::imencode(".jpg", bgr, out, {cv::IMWRITE_JPEG_QUALITY, quality, cv::IMWRITE_JPEG_OPTIMIZE, 1}))
    return make_error(ErrorCode::kInternal, "JPEG encoding failed");
  return out;
}

Image image_from_rgb_mat(const cv::Mat& rgb) {
  Image im = Image::make(rgb.cols, rgb.rows, 3);
  for (int y = 0; y < rgb.rows; ++y)
    std::memcpy(im.pixel(0, y), rgb.ptr<std::uint8_t>(y), static_cast<size_t>(rgb.cols) * 3);
  return im;
}

Status attach_jpeg(Mesh& mesh, int quality, double* encode_ms) {
  const auto t0 = std::chrono::steady_clock::now();
  auto jpeg = encode_jpeg(mesh.texture, quality);
  if (!jpeg) return jpeg.error();
  mesh.texture_encoded = std::move(jpeg.value());
  mesh.texture_mime = "image/jpeg";
  *encode_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return ok_status();
}

}  // namespace rgbdcast
