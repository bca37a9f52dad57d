#include "input/depth_encoding.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <optional>

namespace rgbdcast {

namespace {

constexpr std::uint16_t kNyuNoDepth = 2047;
constexpr double kNyuNumerator = 351.3, kNyuOffset = 1092.5;
constexpr double kSensorMaxM = 20.0;  // the far end of an RGB-D sensor's range (reduction/pipeline.h's median check)

std::uint16_t sun_to_mm(std::uint16_t raw) { return static_cast<std::uint16_t>((raw >> 3) | (raw << 13)); }

// One pass over a depth image in units (png16's raw values, sun's millimetres), in integers: what the checks of
// decode_depth_encoding read. A frame is read for every image a stream tracks, so this pass is on its critical path.
struct UnitStats {
  size_t valid = 0, beyond = 0, multiples_of_8 = 0, at_2047 = 0;
  std::uint16_t max_units = 0;
  // units / depth_scale > kSensorMaxM, for integer units: units > floor(kSensorMaxM * depth_scale).
  UnitStats(const cv::Mat& units16, double depth_scale) {
    const double limit = std::floor(kSensorMaxM * depth_scale);
    const std::uint32_t far = limit >= 65535.0 ? 65535u : limit <= 0.0 ? 0u : static_cast<std::uint32_t>(limit);
    for (int y = 0; y < units16.rows; ++y) {
      const std::uint16_t* row = units16.ptr<std::uint16_t>(y);
      size_t v = 0, f = 0, m8 = 0, a = 0;
      std::uint16_t mx = 0;
      for (int x = 0; x < units16.cols; ++x) {
        const std::uint16_t u = row[x];
        const size_t on = u != 0;
        v += on;
        f += u > far;
        m8 += on & static_cast<size_t>((u & 7) == 0);
        a += u == kNyuNoDepth;
        mx = std::max(mx, u);
      }
      valid += v, beyond += f, multiples_of_8 += m8, at_2047 += a;
      max_units = std::max(max_units, mx);
    }
  }
  // Kinect disparity: nothing above its "no depth" value 2047, which fills at least 1 % of the pixels.
  bool looks_like_disparity() const { return max_units == kNyuNoDepth && at_2047 * 100 >= valid; }
  // SUN's rotation of millimetres below 8.192 m leaves the low 3 bits 0.
  bool looks_rotated() const { return valid > 0 && multiples_of_8 == valid; }
};

// NYU raw disparity to metres (CV_32FC1), counting the valid depths and those beyond the sensor's range.
cv::Mat nyu_to_metres(const cv::Mat& raw16, size_t& valid, size_t& beyond, std::uint16_t& max_raw) {
  cv::Mat out(raw16.size(), CV_32FC1);
  for (int y = 0; y < raw16.rows; ++y) {
    const std::uint16_t* in = raw16.ptr<std::uint16_t>(y);
    float* o = out.ptr<float>(y);
    for (int x = 0; x < raw16.cols; ++x) {
      const std::uint16_t raw = in[x];
      max_raw = std::max(max_raw, raw);
      double z = 0;
      if (raw != kNyuNoDepth && raw < kNyuOffset) z = kNyuNumerator / (kNyuOffset - raw);
      o[x] = static_cast<float>(z);
      if (z > 0) ++valid, beyond += z > kSensorMaxM;
    }
  }
  return out;
}

}  // namespace

std::optional<DepthEncoding> parse_depth_encoding(const std::string& name) {
  if (name == "png16") return DepthEncoding::kPng16;
  if (name == "nyu") return DepthEncoding::kNyu;
  if (name == "sun") return DepthEncoding::kSun;
  return std::nullopt;
}

const char* to_string(DepthEncoding e) {
  switch (e) {
    case DepthEncoding::kNyu:
      return "nyu";
    case DepthEncoding::kSun:
      return "sun";
    case DepthEncoding::kPng16:
      break;
  }
  return "png16";
}

Result<cv::Mat> decode_depth_encoding(const cv::Mat& raw16, DepthEncoding encoding, double depth_scale,
                                      const std::string& what) {
  if (raw16.type() != CV_16UC1)
    return make_error(ErrorCode::kInvalidInput, what + ": depth must be 16-bit, one channel");
  // png16 is returned as it is; the others get an image of their own.
  cv::Mat out;
  size_t valid = 0, beyond = 0;
  std::uint16_t max_raw = 0;
  std::optional<UnitStats> stats;
  if (encoding == DepthEncoding::kNyu) {
    out = nyu_to_metres(raw16, valid, beyond, max_raw);
  } else {
    if (encoding == DepthEncoding::kSun) {
      out = cv::Mat(raw16.size(), CV_16UC1);
      for (int y = 0; y < raw16.rows; ++y) {
        const std::uint16_t* in = raw16.ptr<std::uint16_t>(y);
        std::uint16_t* o = out.ptr<std::uint16_t>(y);
        for (int x = 0; x < raw16.cols; ++x) o[x] = sun_to_mm(in[x]);
      }
    } else {
      out = raw16;
    }
    stats.emplace(out, depth_scale);
    valid = stats->valid;
    beyond = stats->beyond;
  }
  char buf[320];
  std::string hint;
  if (encoding == DepthEncoding::kNyu && max_raw > kNyuNoDepth) {
    std::snprintf(buf, sizeof buf,
                  ": values up to %u do not fit the Kinect's 11-bit disparity (0-2047): not NYU raw depth; is "
                  "--depth-encoding right (png16|nyu|sun)?",
                  unsigned(max_raw));
    return make_error(ErrorCode::kInvalidInput, what + buf);
  }
  if (encoding == DepthEncoding::kPng16) {
    const UnitStats& sig = *stats;  // png16's units are its raw values
    if (sig.looks_like_disparity()) {
      std::snprintf(buf, sizeof buf,
                    ": no value exceeds 2047 and 2047 fills %.0f%% of the valid pixels, as the Kinect's disparity "
                    "marks no depth: is --depth-encoding right (png16|nyu|sun)?",
                    100.0 * double(sig.at_2047) / double(sig.valid));
      return make_error(ErrorCode::kInvalidInput, what + buf);
    }
    hint = sig.looks_rotated() ? " (every value is a multiple of 8, as SUN's bit-rotated depth: --depth-encoding sun?)"
                               : "";
  }
  if (beyond * 10 > valid) {
    std::snprintf(buf, sizeof buf,
                  ": %.0f%% of the valid depths lie beyond %g m as --depth-encoding %s at --depth-scale %g (an RGB-D "
                  "sensor sees 0.2-%g m); are they right?",
                  100.0 * double(beyond) / double(valid), kSensorMaxM, to_string(encoding), depth_scale, kSensorMaxM);
    return make_error(ErrorCode::kInvalidInput, what + buf + hint);
  }
  return out;
}

}  // namespace rgbdcast
