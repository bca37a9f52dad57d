#include "service/image_encode.h"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace rgbdcast::service {

Result<std::vector<std::uint8_t>> encode_image(const Image& image, ImageFormat format, int quality) {
  if (image.empty() || (image.channels != 3 && image.channels != 4) ||
      image.data.size() != static_cast<size_t>(image.width) * image.height * image.channels)
    return make_error(ErrorCode::kInvalidArgument, "cannot encode an empty or malformed image");
  const cv::Mat src(image.height, image.width, image.channels == 4 ? CV_8UC4 : CV_8UC3,
                    const_cast<std::uint8_t*>(image.data.data()));
  cv::Mat bgr;
  std::vector<int> params;
  std::string ext;
  if (format == ImageFormat::kJpeg) {
    cv::cvtColor(src, bgr, image.channels == 4 ? cv::COLOR_RGBA2BGR : cv::COLOR_RGB2BGR);
    params = {cv::IMWRITE_JPEG_QUALITY, quality};
    ext = ".jpg";
  } else {
    cv::cvtColor(src, bgr, image.channels == 4 ? cv::COLOR_RGBA2BGRA : cv::COLOR_RGB2BGR);
    params = {cv::IMWRITE_PNG_COMPRESSION, 1};  // fast: the client is on a network, not an archive
    ext = ".png";
  }
  std::vector<std::uint8_t> out;
  try {
    if (!cv::imencode(ext, bgr, out, params)) return make_error(ErrorCode::kInternal, "image encoder failed");
  } catch (const cv::Exception& e) {
    return make_error(ErrorCode::kInternal, std::string("image encoder failed: ") + e.what());
  }
  return out;
}

}  // namespace rgbdcast::service
