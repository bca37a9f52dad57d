// libFuzzer: the view query parser (service/view_params.cpp) and the camera it builds. The input is a query string
// split on '&' and the first '=' (cpp-httplib has already percent-decoded it); make_view_camera runs with no capture
// camera and with one.
#include <cstdint>
#include <string>

#include "service/view_params.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, size_t size) {
  const std::string q(reinterpret_cast<const char*>(data), size);
  rgbdcast::service::QueryParams params;
  size_t pos = 0;
  while (pos <= q.size()) {
    size_t amp = q.find('&', pos);
    if (amp == std::string::npos) amp = q.size();
    const std::string pair = q.substr(pos, amp - pos);
    const size_t eq = pair.find('=');
    params.emplace(pair.substr(0, eq), eq == std::string::npos ? "" : pair.substr(eq + 1));
    pos = amp + 1;
  }
  auto req = rgbdcast::service::parse_view_request(params);
  if (!req.ok()) return 0;
  (void)rgbdcast::service::make_view_camera(*req, {});
  rgbdcast::CaptureCamera cam;
  cam.intrinsics.fx = cam.intrinsics.fy = 525.0;
  cam.intrinsics.cx = 319.5;
  cam.intrinsics.cy = 239.5;
  cam.intrinsics.width = 640;
  cam.intrinsics.height = 480;
  (void)rgbdcast::service::make_view_camera(*req, {cam});
  return 0;
}
