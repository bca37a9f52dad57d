#include "tests/input/test_bags.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include "input/frame_source.h"
#include "input/intrinsics_io.h"
#include "tests/common/run_command.h"
#include "tests/common/test_data.h"

namespace rgbdcast::test {

namespace {

const char* kFr1 = "tum/rgbd_dataset_freiburg1_xyz";

Status write_raw(const cv::Mat& m, const std::string& path) {
  std::ofstream out(path, std::ios::binary);
  for (int y = 0; y < m.rows; ++y) out.write(m.ptr<const char>(y), std::streamsize(m.cols * m.elemSize()));
  if (!out) return make_error(ErrorCode::kIo, "cannot write " + path);
  return ok_status();
}

Result<std::vector<unsigned char>> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return make_error(ErrorCode::kNotFound, "cannot open " + path);
  return std::vector<unsigned char>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// The depth image as the bag holds it, from the folder's raw 1/5000 m PNG.
cv::Mat bag_depth(const cv::Mat& raw, BagDepth kind, const char** encoding) {
  cv::Mat out;
  switch (kind) {
    case BagDepth::kMetres32F:
      *encoding = "32FC1";
      raw.convertTo(out, CV_32F, 1.0 / 5000.0);  // the same conversion make_frame applies to the folder
      out.setTo(std::numeric_limits<float>::quiet_NaN(), raw == 0);
      break;
    case BagDepth::kMillimetres16U:
      *encoding = "16UC1";
      raw.convertTo(out, CV_16U, 0.2);  // rounds to the nearest millimetre
      break;
    case BagDepth::kTumRaw16U:
      *encoding = "16UC1";
      out = raw;
      break;
  }
  return out;
}

}  // namespace

bool have_bag_writer(std::string* why) {
  auto r = run_command("/usr/bin/python3 -c 'import rosbag, sensor_msgs.msg' 2>&1");
  if (r.exit_code == 0) return true;
  *why =
      "/usr/bin/python3 cannot import rosbag and sensor_msgs (apt-get install python3-rosbag python3-sensor-msgs, "
      "scripts/setup.sh): " +
      r.out;
  return false;
}

MadeBag make_fr1_bag(const std::string& dir, const std::string& name, const BagSpec& spec) {
  MadeBag made;
  const std::string root = data_path(kFr1);
  auto rgb = read_tum_list(root + "/rgb.txt");
  auto depth = read_tum_list(root + "/depth.txt");
  if (!rgb || !depth) {
    made.why_not = "cannot read rgb.txt/depth.txt under " + root;
    return made;
  }
  const Intrinsics k = *intrinsics_preset("fr1");
  nlohmann::json images = nlohmann::json::array();
  int n = 0;
  for (const StampedPath& s : *rgb) {
    auto bytes = read_bytes(root + "/" + s.path);
    if (!bytes) return {false, "", bytes.error().message};
    auto color = decode_color(*bytes, s.path);
    if (!color) return {false, "", color.error().message};
    cv::Mat pixels = *color;
    if (spec.color_encoding == "bgr8") cv::cvtColor(*color, pixels, cv::COLOR_RGB2BGR);
    const std::string file = dir + "/" + name + ".c" + std::to_string(n++) + ".raw";
    if (auto st = write_raw(pixels, file); !st) return {false, "", st.error().message};
    images.push_back({{"topic", "/camera/rgb/image_color"},
                      {"stamp", s.timestamp},
                      {"width", pixels.cols},
                      {"height", pixels.rows},
                      {"encoding", spec.color_encoding},
                      {"step", pixels.cols * 3},
                      {"file", file}});
  }
  for (const StampedPath& s : *depth) {
    auto bytes = read_bytes(root + "/" + s.path);
    if (!bytes) return {false, "", bytes.error().message};
    auto raw = decode_depth16(*bytes, s.path);
    if (!raw) return {false, "", raw.error().message};
    const char* encoding = "";
    const cv::Mat pixels = bag_depth(*raw, spec.depth, &encoding);
    const std::string file = dir + "/" + name + ".d" + std::to_string(n++) + ".raw";
    if (auto st = write_raw(pixels, file); !st) return {false, "", st.error().message};
    images.push_back({{"topic", "/camera/depth/image"},
                      {"stamp", s.timestamp},
                      {"width", pixels.cols},
                      {"height", pixels.rows},
                      {"encoding", encoding},
                      {"step", pixels.cols * int(pixels.elemSize())},
                      {"file", file}});
  }
  nlohmann::json manifest = {{"images", images}, {"compression", spec.compression}};
  if (spec.camera_info)
    manifest["camera_info"] = {{"topic", "/camera/rgb/camera_info"},
                               {"stamp", (*rgb)[0].timestamp},
                               {"width", k.width},
                               {"height", k.height},
                               {"K", {k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0}},
                               {"D", k.distortion},
                               {"distortion_model", "plumb_bob"}};
  const std::string manifest_path = dir + "/" + name + ".json";
  std::ofstream(manifest_path) << manifest.dump();
  made.path = dir + "/" + name + ".bag";
  auto r = run_command("/usr/bin/python3 '" + source_path("tests/input/write_test_bag.py") + "' '" + manifest_path +
                       "' '" + made.path + "' 2>&1");
  for (const auto& image : images) std::remove(image.at("file").get<std::string>().c_str());
  made.ok = r.exit_code == 0;
  if (!made.ok) made.why_not = "write_test_bag.py failed: " + r.out;
  return made;
}

}  // namespace rgbdcast::test
