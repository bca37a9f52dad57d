#pragma once
// Rendered images to JPEG or PNG bytes through OpenCV's codecs (libjpeg-turbo, libpng). JPEG is the default of the
// view route: at 640x480 it costs about 1 ms where PNG costs 12-14 ms, more than the render.
#include <cstddef>  // scene/image.h uses size_t without including it
#include <cstdint>
#include <vector>

#include "scene/image.h"
#include "scene/result.h"
#include "service/view_params.h"

namespace rgbdcast::service {

// image: RGB or RGBA 8-bit (alpha dropped for JPEG, kept for PNG). quality 1..100 applies to JPEG.
Result<std::vector<std::uint8_t>> encode_image(const Image& image, ImageFormat format, int quality);

}  // namespace rgbdcast::service
