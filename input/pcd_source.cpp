#include "input/pcd_source.h"

#include <pcl/console/print.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <cmath>
#include <fstream>
#include <vector>

#include "input/pcd_header.h"

namespace rgbdcast {

namespace {

class PcdSource : public FrameSource {
 public:
  PcdSource(std::string path, Intrinsics k) : path_(std::move(path)), k_(std::move(k)) {
    entries_.push_back({path_, path_, 0.0, 0.0});
  }
  std::string kind() const override { return "pcd"; }
  size_t size() const override { return 1; }
  const Intrinsics& intrinsics() const override { return k_; }
  const std::vector<FrameEntry>& entries() const override { return entries_; }
  std::string root() const override { return path_; }

  Result<RgbdFrame> frame(size_t i) const override {
    if (i != 0)
      return make_error(ErrorCode::kNotFound, "frame " + std::to_string(i) + " is past the end (a PCD holds 1 frame)");
    {
      // rgbdcast reads the header first: PCL trusts it for its buffer sizes.
      std::ifstream in(path_, std::ios::binary);
      if (!in) return make_error(ErrorCode::kNotFound, "cannot open " + path_);
      std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      auto header = check_pcd_header(bytes.data(), bytes.size());
      if (!header) return make_error(header.error().code, path_ + ": " + header.error().message);
    }
    pcl::PointCloud<pcl::PointXYZRGBA> cloud;
    pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);  // errors come back as Result, not on stderr
    int rc = -1;
    try {
      pcl::PCDReader reader;
      rc = reader.read(path_, cloud);
    } catch (const std::exception& e) {
      return make_error(ErrorCode::kInvalidInput, path_ + ": unreadable PCD (" + std::string(e.what()) + ")");
    }
    if (rc < 0) return make_error(ErrorCode::kInvalidInput, path_ + ": unreadable or corrupt PCD");
    if (!cloud.isOrganized() || cloud.width < 2 || cloud.height < 2)
      return make_error(ErrorCode::kInvalidInput, path_ + ": PCD is not organized (needs width x height points)");
    const int w = static_cast<int>(cloud.width), h = static_cast<int>(cloud.height);
    RgbdFrame f;
    f.intrinsics = k_.pinhole();
    f.intrinsics.width = w;
    f.intrinsics.height = h;
    f.color_rgb.create(h, w, CV_8UC3);
    f.depth_m = cv::Mat::zeros(h, w, CV_32F);
    f.xyz_m.create(h, w, CV_32FC3);
    size_t valid = 0;
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const auto& p = cloud.at(x, y);
        f.color_rgb.at<cv::Vec3b>(y, x) = cv::Vec3b(p.r, p.g, p.b);
        const bool ok = std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z) && p.z > 0;
        f.xyz_m.at<cv::Vec3f>(y, x) = ok ? cv::Vec3f(p.x, p.y, p.z) : cv::Vec3f(NAN, NAN, NAN);
        if (ok) {
          f.depth_m.at<float>(y, x) = p.z;
          ++valid;
        }
      }
    }
    if (valid == 0) return make_error(ErrorCode::kEmpty, path_ + ": no valid depth (every point is NaN)");
    f.color_path = f.depth_path = path_;
    return f;
  }

 private:
  std::string path_;
  Intrinsics k_;
  std::vector<FrameEntry> entries_;
};

}  // namespace

Result<std::unique_ptr<FrameSource>> open_pcd_source(const std::string& path, const Intrinsics& intrinsics) {
  return std::unique_ptr<FrameSource>(new PcdSource(path, intrinsics));
}

}  // namespace rgbdcast
