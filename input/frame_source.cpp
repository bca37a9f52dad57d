#include "input/frame_source.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "input/intrinsics_io.h"
#include "input/pcd_source.h"
#ifdef RGBDCAST_HAVE_ROSBAG
#include "input/rosbag_source.h"
#endif
#include "scene/image_probe.h"

namespace fs = std::filesystem;

namespace rgbdcast {

// ---------------------------------------------------------------------------------------------------------------
// Decoding and validation

// A PNG that does not end in an IEND chunk was cut short; saying so here spares the user libpng's own complaint.
static bool truncated_png(const std::vector<unsigned char>& b) {
  static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (b.size() < 8 || !std::equal(sig, sig + 8, b.begin())) return false;
  static const unsigned char iend[8] = {'I', 'E', 'N', 'D', 0xae, 0x42, 0x60, 0x82};
  return b.size() < 20 || !std::equal(iend, iend + 8, b.end() - 8);
}

// The size check in front of both decoders: the header's size against the limits, before any pixel is allocated.
static Status check_frame_header(const std::vector<unsigned char>& bytes, const std::string& what,
                                 const FrameLimits& limits) {
  if (bytes.empty()) return make_error(ErrorCode::kInvalidInput, what + ": empty file");
  if (truncated_png(bytes))
    return make_error(ErrorCode::kInvalidInput, what + ": not a readable image (truncated PNG: no IEND chunk)");
  int w = 0, h = 0;
  if (!probe_image_size(bytes.data(), bytes.size(), &w, &h)) {
    if (limits.png_jpeg_only)
      return make_error(ErrorCode::kInvalidInput, what + ": not a readable PNG or JPEG (corrupt or another format)");
    return ok_status();  // a local file in another format: OpenCV's own limits apply
  }
  const int long_side = std::max(w, h), short_side = std::min(w, h);
  if (long_side > limits.max_long_side_px || short_side > limits.max_short_side_px)
    return make_error(ErrorCode::kInvalidInput,
                      what + ": " + std::to_string(w) + "x" + std::to_string(h) + " is over the frame limit of " +
                          std::to_string(limits.max_long_side_px) + "x" + std::to_string(limits.max_short_side_px));
  return ok_status();
}

static cv::Mat imdecode_or_empty(const std::vector<unsigned char>& bytes, int flags) {
  try {
    return cv::imdecode(bytes, flags);
  } catch (const cv::Exception&) {
    return cv::Mat();
  }
}

Result<cv::Mat> decode_color(const std::vector<unsigned char>& bytes, const std::string& what,
                             const FrameLimits& limits) {
  if (auto st = check_frame_header(bytes, what, limits); !st) return st.error();
  const cv::Mat img = imdecode_or_empty(bytes, cv::IMREAD_UNCHANGED);
  if (img.empty())
    return make_error(ErrorCode::kInvalidInput, what + ": not a readable image (corrupt or unknown format)");
  if (img.depth() != CV_8U)
    return make_error(ErrorCode::kInvalidInput, what + ": colour image must be 8-bit per channel");
  cv::Mat rgb;
  switch (img.channels()) {
    case 1:
      cv::cvtColor(img, rgb, cv::COLOR_GRAY2RGB);
      break;
    case 3:
      cv::cvtColor(img, rgb, cv::COLOR_BGR2RGB);
      break;
    case 4:
      cv::cvtColor(img, rgb, cv::COLOR_BGRA2RGB);
      break;
    default:
      return make_error(ErrorCode::kInvalidInput, what + ": unsupported channel count");
  }
  return rgb;
}

Result<cv::Mat> decode_depth16(const std::vector<unsigned char>& bytes, const std::string& what,
                               const FrameLimits& limits) {
  if (auto st = check_frame_header(bytes, what, limits); !st) return st.error();
  const cv::Mat img = imdecode_or_empty(bytes, cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR);
  if (img.empty())
    return make_error(ErrorCode::kInvalidInput, what + ": not a readable image (corrupt or unknown format)");
  if (img.depth() != CV_16U || img.channels() != 1)
    return make_error(ErrorCode::kInvalidInput, what + ": depth must be a 16-bit single-channel image (got " +
                                                    std::to_string(8 * img.elemSize1()) + "-bit, " +
                                                    std::to_string(img.channels()) + " channel(s))");
  return img;
}

static Result<std::vector<unsigned char>> read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return make_error(ErrorCode::kNotFound, "cannot open " + path);
  std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return bytes;
}

namespace {

// Fixed-point tables (OpenCV's CV_16SC2 + interpolation indices): remap reads them about twice as fast as float
// tables. Colour uses the bilinear pair; depth its own rounded table (nearest: the float table's rounding, not the
// bilinear table's floor, which would shift depth half a pixel against colour).
Undistorter::Maps build_maps(const Intrinsics& k) {
  cv::Mat K = (cv::Mat_<double>(3, 3) << k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
  cv::Mat D(1, 5, CV_64F);
  for (int i = 0; i < 5; ++i) D.at<double>(i) = k.distortion[i];
  Undistorter::Maps maps;
  cv::Mat x, y, unused;
  cv::initUndistortRectifyMap(K, D, cv::Mat(), K, cv::Size(k.width, k.height), CV_32FC1, x, y);
  cv::convertMaps(x, y, maps.linear_xy, maps.linear_frac, CV_16SC2, false);
  cv::convertMaps(x, y, maps.nearest_xy, unused, CV_16SC2, true);
  return maps;
}

bool same_camera(const Intrinsics& a, const Intrinsics& b) {
  return a.fx == b.fx && a.fy == b.fy && a.cx == b.cx && a.cy == b.cy && a.width == b.width && a.height == b.height &&
         a.distortion == b.distortion;
}

}  // namespace

struct Undistorter::State {
  std::mutex mutex;
  Intrinsics k;
  Maps maps;
};
Undistorter::Undistorter() : state_(std::make_unique<State>()) {}
Undistorter::~Undistorter() = default;

Undistorter::Maps Undistorter::maps(const Intrinsics& k) {
  std::lock_guard<std::mutex> lock(state_->mutex);
  if (state_->maps.linear_xy.empty() || !same_camera(state_->k, k)) {
    state_->maps = build_maps(k);
    state_->k = k;
  }
  return state_->maps;  // cv::Mat copies share the (never modified) tables
}

Result<RgbdFrame> make_frame(const cv::Mat& color_rgb, const cv::Mat& depth_raw, const Intrinsics& intrinsics,
                             Undistorter* undistorter) {
  if (color_rgb.size() != depth_raw.size())
    return make_error(ErrorCode::kInvalidInput, "colour (" + std::to_string(color_rgb.cols) + "x" +
                                                    std::to_string(color_rgb.rows) + ") and depth (" +
                                                    std::to_string(depth_raw.cols) + "x" +
                                                    std::to_string(depth_raw.rows) + ") have different sizes");
  if (color_rgb.cols != intrinsics.width || color_rgb.rows != intrinsics.height)
    return make_error(ErrorCode::kInvalidInput, "images are " + std::to_string(color_rgb.cols) + "x" +
                                                    std::to_string(color_rgb.rows) + " but the intrinsics are for " +
                                                    std::to_string(intrinsics.width) + "x" +
                                                    std::to_string(intrinsics.height));
  if (cv::countNonZero(depth_raw) == 0) return make_error(ErrorCode::kEmpty, "no valid depth (every pixel is 0)");
  RgbdFrame f;
  f.intrinsics = intrinsics.pinhole();
  if (intrinsics.has_distortion()) {
    // Both images are resampled onto the ideal pinhole camera with the same K: colour bilinear, depth nearest
    // (interpolating depth across an edge would invent points between foreground and background). Nearest picks a
    // pixel, so the raw depth is resampled before its conversion to metres: the same values, and the 16-bit remap
    // takes half the time of a float one (0.85 against 1.7 ms for both images and the conversion, TUM 640x480).
    const Undistorter::Maps maps = undistorter ? undistorter->maps(intrinsics) : build_maps(intrinsics);
    cv::remap(color_rgb, f.color_rgb, maps.linear_xy, maps.linear_frac, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
    cv::Mat depth_undistorted;
    cv::remap(depth_raw, depth_undistorted, maps.nearest_xy, cv::Mat(), cv::INTER_NEAREST, cv::BORDER_CONSTANT, 0);
    depth_undistorted.convertTo(f.depth_m, CV_32F, 1.0 / intrinsics.depth_scale);
  } else {
    f.color_rgb = color_rgb.clone();
    depth_raw.convertTo(f.depth_m, CV_32F, 1.0 / intrinsics.depth_scale);
  }
  return f;
}

static Result<RgbdFrame> load_pair(const FrameEntry& e, const Intrinsics& intrinsics, DepthEncoding encoding,
                                   Undistorter* undistorter) {
  auto cbytes = read_file(e.color_path);
  if (!cbytes) return cbytes.error();
  auto dbytes = read_file(e.depth_path);
  if (!dbytes) return dbytes.error();
  auto color = decode_color(*cbytes, e.color_path, FrameLimits::local_files());
  if (!color) return color.error();
  auto raw = decode_depth16(*dbytes, e.depth_path, FrameLimits::local_files());
  if (!raw) return raw.error();
  auto depth = decode_depth_encoding(*raw, encoding, intrinsics.depth_scale, e.depth_path);
  if (!depth) return depth.error();
  // nyu decodes to metres (scale 1); the frame still reports the source's scale.
  Intrinsics k = intrinsics;
  if (depth->type() == CV_32FC1) k.depth_scale = 1.0;
  auto frame = make_frame(*color, *depth, k, undistorter);
  if (!frame) return make_error(frame.error().code, e.depth_path + ": " + frame.error().message);
  frame->intrinsics.depth_scale = intrinsics.depth_scale;
  frame->timestamp = e.color_timestamp;
  frame->color_path = e.color_path;
  frame->depth_path = e.depth_path;
  return frame;
}

// ---------------------------------------------------------------------------------------------------------------
// TUM association

Result<std::vector<StampedPath>> read_tum_list(const std::string& path) {
  std::ifstream in(path);
  if (!in) return make_error(ErrorCode::kNotFound, "cannot open " + path);
  std::vector<StampedPath> out;
  std::string line;
  int lineno = 0;
  while (std::getline(in, line)) {
    ++lineno;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    StampedPath sp;
    if (!(ss >> sp.timestamp >> sp.path) || !std::isfinite(sp.timestamp))
      return make_error(ErrorCode::kInvalidInput,
                        path + ":" + std::to_string(lineno) + ": expected \"timestamp path\"");
    out.push_back(sp);
  }
  return out;
}

std::vector<FrameEntry> associate(const std::vector<StampedPath>& rgb, const std::vector<StampedPath>& depth,
                                  double max_difference_s) {
  // As associate.py: all candidate pairs within the limit, taken greedily by smallest difference, each stamp once.
  struct Candidate {
    double diff;
    size_t r, d;
  };
  std::vector<Candidate> candidates;
  std::vector<size_t> depth_order(depth.size());
  for (size_t i = 0; i < depth.size(); ++i) depth_order[i] = i;
  std::sort(depth_order.begin(), depth_order.end(),
            [&](size_t a, size_t b) { return depth[a].timestamp < depth[b].timestamp; });
  for (size_t r = 0; r < rgb.size(); ++r) {
    const double t = rgb[r].timestamp;
    auto lo = std::lower_bound(depth_order.begin(), depth_order.end(), t - max_difference_s,
                               [&](size_t d, double v) { return depth[d].timestamp < v; });
    for (auto it = lo; it != depth_order.end() && depth[*it].timestamp <= t + max_difference_s; ++it) {
      const double diff = std::abs(depth[*it].timestamp - t);
      if (diff < max_difference_s) candidates.push_back({diff, r, *it});
    }
  }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Candidate& a, const Candidate& b) { return a.diff < b.diff; });
  std::vector<bool> rgb_used(rgb.size()), depth_used(depth.size());
  std::vector<FrameEntry> out;
  for (const auto& c : candidates) {
    if (rgb_used[c.r] || depth_used[c.d]) continue;
    rgb_used[c.r] = depth_used[c.d] = true;
    out.push_back({rgb[c.r].path, depth[c.d].path, rgb[c.r].timestamp, depth[c.d].timestamp});
  }
  std::sort(out.begin(), out.end(),
            [](const FrameEntry& a, const FrameEntry& b) { return a.color_timestamp < b.color_timestamp; });
  return out;
}

// ---------------------------------------------------------------------------------------------------------------
// Sources

namespace {

class ListSource : public FrameSource {
 public:
  ListSource(std::string kind, std::string root, std::vector<FrameEntry> entries, Intrinsics k, DepthEncoding encoding)
      : kind_(std::move(kind)),
        root_(std::move(root)),
        entries_(std::move(entries)),
        k_(std::move(k)),
        encoding_(encoding) {}
  std::string kind() const override { return kind_; }
  size_t size() const override { return entries_.size(); }
  const Intrinsics& intrinsics() const override { return k_; }
  const std::vector<FrameEntry>& entries() const override { return entries_; }
  std::string root() const override { return root_; }
  Result<RgbdFrame> frame(size_t i) const override {
    if (i >= entries_.size())
      return make_error(ErrorCode::kNotFound, "frame " + std::to_string(i) + " is past the end (" + root_ + " has " +
                                                  std::to_string(entries_.size()) + " frames)");
    auto f = load_pair(entries_[i], k_, encoding_, &undistorter_);
    if (f) f->index = static_cast<int>(i);
    return f;
  }

 private:
  std::string kind_, root_;
  std::vector<FrameEntry> entries_;
  Intrinsics k_;
  DepthEncoding encoding_;
  mutable Undistorter undistorter_;  // the camera's tables, made on the first frame
};

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

Result<Intrinsics> pick_intrinsics(const SourceOptions& o, const std::string& guess) {
  auto k = resolve_intrinsics(o.intrinsics.empty() ? guess : o.intrinsics);
  if (!k) return k;
  if (o.depth_scale) {
    if (!(*o.depth_scale > 0) || !std::isfinite(*o.depth_scale))
      return make_error(ErrorCode::kInvalidArgument, "--depth-scale must be positive");
    k->depth_scale = *o.depth_scale;
  } else if (o.depth_encoding == DepthEncoding::kSun) {
    k->depth_scale = 1000.0;  // sun stores millimetres, whatever the camera preset's own unit
  }
  return k;
}

// A list source over `entries`. Intrinsics without a size (a 3x3 matrix file) take it from the first colour image.
Result<std::unique_ptr<FrameSource>> make_list_source(std::string kind, std::string root,
                                                      std::vector<FrameEntry> entries, Intrinsics k,
                                                      const SourceOptions& o) {
  if (k.width == 0 && !entries.empty()) {
    auto bytes = read_file(entries[0].color_path);
    if (!bytes) return bytes.error();
    auto color = decode_color(*bytes, entries[0].color_path, FrameLimits::local_files());
    if (!color) return color.error();
    k.width = color->cols;
    k.height = color->rows;
  }
  return std::unique_ptr<FrameSource>(
      new ListSource(std::move(kind), std::move(root), std::move(entries), std::move(k), o.depth_encoding));
}

// Numbered images in a folder, sorted by their number (1.png, 2.png, ... or 00000.jpg, ...).
std::vector<std::string> numbered_images(const fs::path& dir) {
  std::vector<std::pair<long, std::string>> items;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string ext = lower(e.path().extension().string());
    if (ext != ".png" && ext != ".jpg" && ext != ".jpeg") continue;
    const std::string stem = e.path().stem().string();
    char* end = nullptr;
    long n = std::strtol(stem.c_str(), &end, 10);
    if (end == stem.c_str()) n = -1;
    items.emplace_back(n, e.path().string());
  }
  std::sort(items.begin(), items.end());
  std::vector<std::string> out;
  for (auto& [n, p] : items) out.push_back(p);
  return out;
}

Result<std::unique_ptr<FrameSource>> open_tum(const fs::path& dir, const SourceOptions& o) {
  std::vector<FrameEntry> entries;
  if (!o.associations_path.empty()) {
    std::ifstream in(o.associations_path);
    if (!in) return make_error(ErrorCode::kNotFound, "cannot open associations file " + o.associations_path);
    std::string line;
    while (std::getline(in, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream ss(line);
      FrameEntry e;
      if (!(ss >> e.color_timestamp >> e.color_path >> e.depth_timestamp >> e.depth_path))
        return make_error(ErrorCode::kInvalidInput,
                          o.associations_path + ": expected \"t_rgb rgb/.. t_depth depth/..\"");
      e.color_path = (dir / e.color_path).string();
      e.depth_path = (dir / e.depth_path).string();
      entries.push_back(e);
    }
  } else {
    auto rgb = read_tum_list((dir / "rgb.txt").string());
    if (!rgb) return rgb.error();
    auto depth = read_tum_list((dir / "depth.txt").string());
    if (!depth) return depth.error();
    entries = associate(*rgb, *depth, o.max_time_difference_s);
    for (auto& e : entries) {
      e.color_path = (dir / e.color_path).string();
      e.depth_path = (dir / e.depth_path).string();
    }
  }
  const std::string name = lower(dir.string());
  std::string guess = "kinect";
  if (name.find("freiburg1") != std::string::npos)
    guess = "fr1";
  else if (name.find("freiburg2") != std::string::npos)
    guess = "fr2";
  else if (name.find("freiburg3") != std::string::npos)
    guess = "fr3";
  auto k = pick_intrinsics(o, guess);
  if (!k) return k.error();
  return make_list_source("tum", dir.string(), std::move(entries), *k, o);
}

Result<std::unique_ptr<FrameSource>> open_numbered(const fs::path& dir, const SourceOptions& o) {
  auto colors = numbered_images(dir / "color");
  auto depths = numbered_images(dir / "depth");
  if (colors.size() != depths.size())
    return make_error(ErrorCode::kInvalidInput, dir.string() + ": color/ has " + std::to_string(colors.size()) +
                                                    " images but depth/ has " + std::to_string(depths.size()));
  std::vector<FrameEntry> entries;
  for (size_t i = 0; i < colors.size(); ++i) entries.push_back({colors[i], depths[i], double(i), double(i)});
  // Redwood/Open3D: millimetre depth and an Open3D camera JSON beside the folders; ICL-NUIM: TUM-style 5000/m.
  std::string guess = "kinect";
  double scale = 1000.0;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string fname = lower(e.path().filename().string());
    if (e.path().extension() == ".json" &&
        (fname.find("camera") != std::string::npos || fname.find("intrinsic") != std::string::npos))
      guess = e.path().string();
  }
  // ICL-NUIM: its pose.txt beside color/ and depth/ (or its name) tells it apart from Redwood.
  if (guess == "kinect" &&
      (fs::exists(dir / "pose.txt") || lower(dir.string()).find("icl_nuim") != std::string::npos)) {
    guess = "icl";
    scale = 5000.0;
  }
  auto k = pick_intrinsics(o, guess);
  if (!k) return k.error();
  // The layout decides the unit unless --depth-scale (or sun's millimetres) says otherwise.
  if (!o.depth_scale && o.depth_encoding != DepthEncoding::kSun) k->depth_scale = scale;
  return make_list_source("redwood", dir.string(), std::move(entries), *k, o);
}

}  // namespace

Result<std::unique_ptr<FrameSource>> open_frame_source(const std::string& path, const SourceOptions& options) {
  std::error_code ec;
  const fs::path p(path);
  if (!fs::exists(p, ec)) return make_error(ErrorCode::kNotFound, "no such file or folder: " + path);
  if (fs::is_directory(p)) {
    if (fs::exists(p / "rgb.txt") || !options.associations_path.empty()) return open_tum(p, options);
    if (fs::is_directory(p / "color") && fs::is_directory(p / "depth")) return open_numbered(p, options);
    return make_error(ErrorCode::kInvalidInput,
                      path + ": not a TUM folder (rgb.txt, depth.txt) nor a color/ + depth/ folder");
  }
  const std::string ext = lower(p.extension().string());
  if ((ext == ".bag" || ext == ".pcd") && options.depth_encoding != DepthEncoding::kPng16)
    return make_error(ErrorCode::kInvalidArgument,
                      path + ": --depth-encoding applies to depth image files, not to a " + ext);
  if (ext == ".bag") {
#ifdef RGBDCAST_HAVE_ROSBAG
    return open_rosbag_source(path, options);
#else
    return make_error(ErrorCode::kUnavailable, path +
                                                   ": this build has no ROS bag support (install "
                                                   "librosbag-storage-dev and libsensor-msgs-dev, scripts/setup.sh)");
#endif
  }
  if (ext == ".pcd") {
    auto k = pick_intrinsics(options, "kinect");
    if (!k) return k.error();
    return open_pcd_source(path, *k);
  }
  if (options.depth_path.empty())
    return make_error(ErrorCode::kInvalidArgument, path + ": a single colour image needs its depth image (--depth)");
  if (!fs::exists(options.depth_path, ec))
    return make_error(ErrorCode::kNotFound, "no such file: " + options.depth_path);
  auto k = pick_intrinsics(options, "kinect");
  if (!k) return k.error();
  std::vector<FrameEntry> entries{{fs::absolute(p).string(), fs::absolute(options.depth_path).string(), 0.0, 0.0}};
  return make_list_source("pair", path, std::move(entries), *k, options);
}

}  // namespace rgbdcast
