#include "atlas/texture_fidelity.h"

#include <cmath>
#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "atlas/frame_texture.h"

namespace rgbdcast {

TextureFidelity measure_texture_fidelity(const Mesh& mesh, const Image& texture, const cv::Mat& color_rgb,
                                         const Intrinsics& k, int n) {
  TextureFidelity f;
  if (texture.empty() || texture.channels != 3 || mesh.uvs.size() != mesh.positions.size() || n < 1) return f;
  const cv::Mat tex(texture.height, texture.width, CV_8UC3, const_cast<std::uint8_t*>(texture.data.data()));
  double sq = 0, abs_sum = 0;
  size_t count = 0;
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    const std::uint32_t i0 = mesh.indices[3 * t], i1 = mesh.indices[3 * t + 1], i2 = mesh.indices[3 * t + 2];
    for (int a = 0; a <= n; ++a)
      for (int b = 0; a + b <= n; ++b) {
        const float b1 = float(a) / n, b2 = float(b) / n, b0 = 1 - b1 - b2;
        const Eigen::Vector3f X = b0 * mesh.positions[i0] + b1 * mesh.positions[i1] + b2 * mesh.positions[i2];
        if (X.z() <= 0) continue;
        const Eigen::Vector2f uv = b0 * mesh.uvs[i0] + b1 * mesh.uvs[i1] + b2 * mesh.uvs[i2];
        const Eigen::Vector2d px = k.project(X.cast<double>());
        if (px.x() < 0 || px.y() < 0 || px.x() > color_rgb.cols - 1 || px.y() > color_rgb.rows - 1) continue;
        std::uint8_t want[3], got[3];
        atlas_detail::sample_bilinear(color_rgb, px.x(), px.y(), want);
        atlas_detail::sample_bilinear(tex, double(uv.x()) * texture.width - 0.5, double(uv.y()) * texture.height - 0.5,
                                      got);
        for (int c = 0; c < 3; ++c) {
          const double d = double(want[c]) - double(got[c]);
          sq += d * d;
          abs_sum += std::abs(d);
        }
        count += 3;
      }
  }
  if (count == 0) return f;
  const double mse = sq / count;
  f.psnr_db = mse > 0 ? 10.0 * std::log10(255.0 * 255.0 / mse) : 99.0;
  f.mean_abs = abs_sum / count;
  f.samples = count / 3;
  return f;
}

Image decode_texture(const Mesh& mesh) {
  if (mesh.texture_encoded.empty()) return {};
  const cv::Mat bgr = cv::imdecode(mesh.texture_encoded, cv::IMREAD_COLOR);
  if (bgr.empty()) return {};
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  Image im = Image::make(rgb.cols, rgb.rows, 3);
  for (int y = 0; y < rgb.rows; ++y) std::memcpy(im.pixel(0, y), rgb.ptr(y), size_t(rgb.cols) * 3);
  return im;
}

}  // namespace rgbdcast
