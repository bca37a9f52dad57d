#include "pipeline/frame_defaults.h"

#include <algorithm>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "base/worker_threads.h"

namespace rgbdcast {

GeometryCodec default_geometry_codec(Preset preset) {
  return preset == Preset::kRealtime ? GeometryCodec::kDraco : GeometryCodec::kMeshopt;
}

Result<JpegPng16> encode_jpeg_png16(const RgbdFrame& frame, int jpeg_quality, int depth_step) {
  if (frame.color_rgb.empty() || frame.depth_m.empty() || depth_step < 1)
    return make_error(ErrorCode::kInvalidArgument, "JPEG + PNG16 payload: an empty frame or a depth step below 1");
  JpegPng16 out;
  // The two encodes are single-threaded and independent: the depth's on a second thread (the estimate of the
  // default budget then costs the longer of the two, not their sum).
  bool png_ok = false;
  BesideThread depth([&] {
    cv::Mat depth_raw;
    // Back to the sensor's units (what a driver publishes); the frame's metres came from exactly these integers.
    frame.depth_m.convertTo(depth_raw, CV_16U, frame.intrinsics.depth_scale);
    if (depth_step > 1)
      cv::resize(depth_raw, depth_raw, cv::Size(depth_raw.cols / depth_step, depth_raw.rows / depth_step), 0, 0,
                 cv::INTER_NEAREST);
    png_ok = cv::imencode(".png", depth_raw, out.png);
  });
  cv::Mat bgr;
  cv::cvtColor(frame.color_rgb, bgr, cv::COLOR_RGB2BGR);
  const bool jpeg_ok = cv::imencode(".jpg", bgr, out.jpeg, {cv::IMWRITE_JPEG_QUALITY, jpeg_quality});
  depth.join();
  if (!jpeg_ok || !png_ok) return make_error(ErrorCode::kInternal, "OpenCV could not encode the images");
  return out;
}

Result<double> payload_share_kb(const RgbdFrame& frame) {
  auto payload = encode_jpeg_png16(frame, 90);
  if (!payload) return payload.error();
  return std::max(4.0, kDefaultBudgetPayloadShare * static_cast<double>(payload->bytes()) / 1000.0);
}

Result<double> default_budget_kb(const RgbdFrame& frame) {
  auto share = payload_share_kb(frame);
  if (!share) return share.error();
  return std::min(kDefaultBudgetKb, *share);
}

}  // namespace rgbdcast
