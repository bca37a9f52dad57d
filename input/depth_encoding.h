#pragma once
// How a dataset stores depth in its 16-bit images, and the decoding of each into metres.
#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "scene/result.h"

namespace rgbdcast {

enum class DepthEncoding {
  kPng16,  // raw units, depth_m = raw / depth_scale (TUM 5000, millimetre sensors 1000); 0 = no reading
  kNyu,    // NYU Depth v2 raw PGM: the Kinect's 11-bit disparity, depth_m = 351.3 / (1092.5 - raw); 2047 = no reading
  kSun,    // SUN3D / SUN RGB-D PNG: millimetres with the 16 bits rotated left by 3, raw = (d << 3) | (d >> 13)
};

// "png16", "nyu", "sun"; nullopt for anything else.
std::optional<DepthEncoding> parse_depth_encoding(const std::string& name);
const char* to_string(DepthEncoding e);

// Decodes a CV_16UC1 depth image into what make_frame (frame_source.h) takes: for png16 the image itself, for sun the
// millimetres (both CV_16UC1 in units of depth_scale), for nyu CV_32FC1 metres (the disparity formula gives metres by
// itself, so depth_scale does not apply; a disparity at or past 1092.5, with no finite positive depth, is no reading).
// 0 is no reading in every encoding.
//
// Values that cannot be a depth image in this encoding at this scale are a kInvalidInput error, one line, prefixed
// with `what`, naming --depth-encoding and --depth-scale:
//  - nyu: a value above 2047 (the Kinect's disparity has 11 bits);
//  - png16: no value above 2047 with 2047 on at least 1 % of the valid pixels (Kinect disparity's "no depth");
//  - png16 and sun: more than a tenth of the valid pixels beyond 20 m (an RGB-D sensor sees 0.2-20 m; the same range
//    as the median check of reduction/pipeline.h); for png16 with a hint when every value is a multiple of 8, as
//    sun's rotation leaves them.
Result<cv::Mat> decode_depth_encoding(const cv::Mat& raw16, DepthEncoding encoding, double depth_scale,
                                      const std::string& what);

}  // namespace rgbdcast
