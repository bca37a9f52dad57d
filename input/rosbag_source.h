#pragma once
// ROS 1 bags (rosbag format 2.0) as a frame source, through Debian's librosbag-storage-dev. Kept in its own
// translation unit: the ROS headers (Boost, pluginlib) stay here.
#include <memory>
#include <string>

#include "input/frame_source.h"

namespace rgbdcast {

// Opens a bag and indexes its frames: sensor_msgs/Image messages on options.rosbag.color_topic and depth_topic,
// paired by header stamp (nearest, within options.max_time_difference_s, as TUM's associate.py), in colour stamp
// order. Intrinsics and distortion come from the first sensor_msgs/CameraInfo on camera_info_topic, unless
// options.intrinsics names a preset or file. 16UC1 depth is millimetres (options.depth_scale overrides 1000 raw
// units per metre); 32FC1 depth is metres. Errors, each one line naming the bag: kNotFound (no file), kInvalidInput
// (not a bag, truncated or corrupt, a topic missing or of the wrong type: the message lists the bag's topics,
// an unsupported encoding or camera model), kEmpty (no colour/depth pair within the limit). frame(i) is safe to call
// from several threads (reads are serialised on the open bag).
Result<std::unique_ptr<FrameSource>> open_rosbag_source(const std::string& path, const SourceOptions& options);

}  // namespace rgbdcast
