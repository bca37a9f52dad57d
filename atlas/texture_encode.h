#pragma once
// Encoding and decoding textures (OpenCV codecs). Image is RGB8/RGBA8 (scene/image.h); cv::Mat is RGB order here.
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "scene/image.h"
#include "scene/mesh.h"
#include "scene/result.h"

namespace rgbdcast {

// JPEG bytes of an RGB8 image; quality 1..100. `optimize_huffman` builds the image's own Huffman tables (a second
// pass over its coefficients): the same pixels in 2-4 % fewer bytes at q50-92 (12 % at q20), at 2-3x the time
// (640x480 TUM frame, libjpeg-turbo 2.1: q92 2.66 against 0.84 ms, q50 1.37 against 0.62 ms).
Result<std::vector<std::uint8_t>> encode_jpeg(const Image& rgb, int quality, bool optimize_huffman = true);
// Encodes mesh.texture as JPEG into mesh.texture_encoded / texture_mime; the time it took goes to *encode_ms.
Status attach_jpeg(Mesh& mesh, int quality, double* encode_ms);
// Copies a CV_8UC3 RGB Mat into an Image.
Image image_from_rgb_mat(const cv::Mat& rgb);

}  // namespace rgbdcast
