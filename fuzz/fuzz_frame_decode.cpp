// libFuzzer: PNG/JPEG bytes -> decode_color and decode_depth16 (upload limits), then make_frame with a distorted
// camera of the decoded size, as the frame upload does.
#include <cstdint>
#include <vector>

#include "input/frame_source.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, size_t size) {
  const std::vector<unsigned char> bytes(data, data + size);
  auto color = rgbdcast::decode_color(bytes, "color");
  auto depth = rgbdcast::decode_depth16(bytes, "depth");
  if (depth.ok()) {
    rgbdcast::Intrinsics k;
    k.width = depth->cols;
    k.height = depth->rows;
    k.fx = k.fy = 525.0;
    k.cx = 0.5 * k.width;
    k.cy = 0.5 * k.height;
    k.distortion = {0.26, -0.95, -0.005, 0.003, 1.16};
    k.depth_scale = 5000.0;
    cv::Mat grey(depth->rows, depth->cols, CV_8UC3, cv::Scalar(90, 90, 90));
    (void)rgbdcast::make_frame(grey, *depth, k);
  }
  return 0;
}
