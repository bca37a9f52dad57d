#pragma once
// ROS 1 bags made at test time from the shared TUM fr1/xyz frames, with Debian's python3-rosbag (tests/input/
// write_test_bag.py). The test decides every pixel: this helper decodes the folder's PNGs, converts them to the bag's
// encodings and hands the raw buffers to the script, so a bag holds exactly what the folder holds in another form.
#include <string>

#include "tests/common/test_data.h"

namespace rgbdcast::test {

enum class BagDepth {
  kMetres32F,       // 32FC1 metres, exactly what the folder's frames hold before undistortion (NaN = no reading)
  kMillimetres16U,  // 16UC1 millimetres (REP 118): the folder's 1/5000 m values rounded to the nearest mm
  kTumRaw16U,       // 16UC1 holding the folder's raw 1/5000 m values (read with depth_scale 5000)
};

struct BagSpec {
  BagDepth depth = BagDepth::kMetres32F;
  std::string color_encoding = "rgb8";  // rgb8 or bgr8: the colour pixels are converted; anything else is written
                                        // as rgb8 bytes under that name (for the unsupported-encoding test)
  bool camera_info = true;              // fr1's published intrinsics and distortion as a sensor_msgs/CameraInfo
  std::string compression = "none";     // rosbag chunk compression: none, bz2 or lz4
};

struct MadeBag {
  bool ok = false;
  std::string path, why_not;  // why_not: the script's or Python's error when !ok
};

// Writes `name`.bag into `dir` with every rgb and depth image of tum/rgbd_dataset_freiburg1_xyz (4 colour, 3 depth)
// on the openni/TUM default topics, stamped as rgb.txt and depth.txt say.
MadeBag make_fr1_bag(const std::string& dir, const std::string& name, const BagSpec& spec);

// True when /usr/bin/python3 imports rosbag and sensor_msgs; otherwise `why` says what is missing.
bool have_bag_writer(std::string* why);

}  // namespace rgbdcast::test

// Skips (fails under CI=true) when the bag writer's Python modules are missing.
#define REQUIRE_BAG_WRITER()                                                                              \
  do {                                                                                                    \
    std::string rgbdcast_why_;                                                                            \
    if (!::rgbdcast::test::have_bag_writer(&rgbdcast_why_)) RGBDCAST_MISSING_PREREQUISITE(rgbdcast_why_); \
  } while (0)
