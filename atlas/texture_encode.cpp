#include "atlas/texture_encode.h"

#include <chrono>

#include <csetjmp>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <jpeglib.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "base/stopwatch.h"

namespace rgbdcast {

namespace {

// libjpeg reports errors through error_exit, which must not return: it jumps back to the encode that failed.
struct JpegError {
  jpeg_error_mgr mgr;
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX];
};

void jpeg_error_exit(j_common_ptr cinfo) {
  auto* e = reinterpret_cast<JpegError*>(cinfo->err);
  (*cinfo->err->format_message)(cinfo, e->message);
  std::longjmp(e->jump, 1);
}

}  // namespace

// libjpeg(-turbo) straight from the RGB rows: the settings OpenCV's imencode used here (4:2:0, optimized Huffman
// tables unless asked not to, the integer DCT), without its copy into BGR and back (the bytes are the same).
Result<std::vector<std::uint8_t>> encode_jpeg(const Image& rgb, int quality, bool optimize_huffman) {
  if (rgb.empty() || rgb.channels != 3) return make_error(ErrorCode::kInvalidArgument, "JPEG needs an RGB8 image");
  if (quality < 1 || quality > 100)
    return make_error(ErrorCode::kInvalidArgument, "JPEG quality must be 1..100, got " + std::to_string(quality));
  jpeg_compress_struct cinfo{};
  JpegError err{};
  cinfo.err = jpeg_std_error(&err.mgr);
  err.mgr.error_exit = jpeg_error_exit;
  unsigned char* buffer = nullptr;  // libjpeg's, freed below
  unsigned long size = 0;
  if (setjmp(err.jump)) {
    jpeg_destroy_compress(&cinfo);
    std::free(buffer);
    return make_error(ErrorCode::kInternal, std::string("JPEG encoding failed: ") + err.message);
  }
  jpeg_create_compress(&cinfo);
  jpeg_mem_dest(&cinfo, &buffer, &size);
  cinfo.image_width = static_cast<JDIMENSION>(rgb.width);
  cinfo.image_height = static_cast<JDIMENSION>(rgb.height);
  cinfo.input_components = 3;
  cinfo.in_color_space = JCS_RGB;
  jpeg_set_defaults(&cinfo);
  jpeg_set_quality(&cinfo, quality, TRUE);
  cinfo.optimize_coding = optimize_huffman ? TRUE : FALSE;
  jpeg_start_compress(&cinfo, TRUE);
  const size_t stride = static_cast<size_t>(rgb.width) * 3;
  while (cinfo.next_scanline < cinfo.image_height) {
    JSAMPROW row = const_cast<JSAMPROW>(rgb.data.data() + cinfo.next_scanline * stride);
    jpeg_write_scanlines(&cinfo, &row, 1);
  }
  jpeg_finish_compress(&cinfo);
  jpeg_destroy_compress(&cinfo);
  std::vector<std::uint8_t> out(buffer, buffer + size);
  std::free(buffer);
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
  *encode_ms = ms_since(t0);
  return ok_status();
}

}  // namespace rgbdcast
