#pragma once
// Encoding and decoding textures (OpenCV codecs). Image is RGB8/RGBA8 (scene/image.h); cv::Mat is RGB order here.
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "scene/image.h"
#include "scene/result.h"

namespace rgbdcast {

// JPEG bytes of an RGB8 image; quality 1..100.
Result<std::vector<std::uint8_t>> encode_jpeg(const Image& rgb, int quality);
// Copies a CV_8UC3 RGB Mat into an Image.
Image image_from_rgb_mat(const cv::Mat& rgb);

}  // namespace rgbdcast
