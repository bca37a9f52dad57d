#include <cmath>

#include "reduction/stages.h"

namespace rgbdcast {

Cloud::Ptr backproject_valid(const RgbdFrame& frame, std::vector<int>* pixel_of_point) {
  auto cloud = std::make_shared<Cloud>();
  const int w = frame.depth_m.cols, h = frame.depth_m.rows;
  cloud->reserve(static_cast<size_t>(w) * h);
  const Intrinsics& k = frame.intrinsics;
  const double inv_fx = 1.0 / k.fx, inv_fy = 1.0 / k.fy;
  const bool organized = !frame.xyz_m.empty();
  if (pixel_of_point) {
    pixel_of_point->clear();
    pixel_of_point->reserve(static_cast<size_t>(w) * h);
  }
  for (int v = 0; v < h; ++v) {
    const float* depth = frame.depth_m.ptr<float>(v);
    const cv::Vec3b* rgb = frame.color_rgb.ptr<cv::Vec3b>(v);
    const cv::Vec3f* xyz = organized ? frame.xyz_m.ptr<cv::Vec3f>(v) : nullptr;
    for (int u = 0; u < w; ++u) {
      CloudPoint p;
      if (organized) {
        if (!std::isfinite(xyz[u][2]) || xyz[u][2] <= 0.f) continue;
        p.x = xyz[u][0];
        p.y = xyz[u][1];
        p.z = xyz[u][2];
      } else {
        const float z = depth[u];
        if (!(z > 0.f) || !std::isfinite(z)) continue;
        p.x = static_cast<float>((u - k.cx) * inv_fx * z);
        p.y = static_cast<float>((v - k.cy) * inv_fy * z);
        p.z = z;
      }
      p.r = rgb[u][0];
      p.g = rgb[u][1];
      p.b = rgb[u][2];
      cloud->push_back(p);
      if (pixel_of_point) pixel_of_point->push_back(v * w + u);
    }
  }
  cloud->width = static_cast<std::uint32_t>(cloud->size());
  cloud->height = 1;
  cloud->is_dense = true;
  return cloud;
}

}  // namespace rgbdcast
