#include "input/rosbag_source.h"

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>

#include "input/intrinsics_io.h"
#include "input/rosbag_check.h"
#include "input/ros_image.h"
#include "scene/error_text.h"

namespace rgbdcast {

namespace {

// Where one image message sits in the bag: its bag time finds it again through the index, its header stamp tells it
// apart from another message of the same topic recorded at the same instant.
struct ImageRef {
  ros::Time bag_time, stamp;
};

RosImageView view_of(const sensor_msgs::Image& m) {
  return {m.encoding, m.width, m.height, m.step, m.is_bigendian != 0, m.data.data(), m.data.size()};
}

// m's message as an M, deserialized from its bytes only after check_ros_message walked them: rosbag's instantiate()
// deserializes straight from the bag, and ROS allocates whatever length a string or an array claims before it finds
// the bytes missing. A null pointer when m is not an M (as instantiate() gives); kInvalidInput when the bytes do not
// hold the layout. The bytes themselves are bounded by the record, which check_rosbag_file has placed in its chunk.
template <class M>
Result<boost::shared_ptr<M>> read_message(const rosbag::MessageInstance& m, RosMessageLayout layout) {
  if (!m.isType<M>()) return boost::shared_ptr<M>();
  std::vector<std::uint8_t> bytes(m.size());
  ros::serialization::OStream out(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
  m.write(out);
  if (auto st = check_ros_message(layout, bytes.data(), bytes.size()); !st) return st.error();
  auto msg = boost::make_shared<M>();
  ros::serialization::IStream in(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
  ros::serialization::deserialize(in, *msg);
  return msg;
}

std::string stamp_label(const std::string& bag, const std::string& topic, const ros::Time& t) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%u.%06u", t.sec, t.nsec / 1000);
  return bag + ":" + topic + "@" + buf;
}

class RosbagSource : public FrameSource {
 public:
  RosbagSource(std::string path, RosbagTopics topics, Intrinsics k)
      : path_(std::move(path)), topics_(std::move(topics)), k_(std::move(k)) {}

  // Opens the bag and reads what the constructor cannot fail on: topics, camera, the stamp index.
  Status open(const SourceOptions& o);

  std::string kind() const override { return "rosbag"; }
  size_t size() const override { return entries_.size(); }
  const Intrinsics& intrinsics() const override { return k_; }
  const std::vector<FrameEntry>& entries() const override { return entries_; }
  std::string root() const override { return path_; }
  Result<RgbdFrame> frame(size_t i) const override;

 private:
  Error bad(const std::string& why) const { return make_error(ErrorCode::kInvalidInput, path_ + ": " + why); }
  Status check_topic(const std::string& topic, const char* type, const char* option, const char* hint = "") const;
  std::string topic_list() const;
  Result<std::vector<StampedPath>> index_images(const std::string& topic, bool depth, std::vector<ImageRef>* refs);
  // The image message `ref` of `topic` (the bag must be locked).
  Result<sensor_msgs::Image::ConstPtr> read_image(const std::string& topic, const ImageRef& ref) const;

  std::string path_;
  RosbagTopics topics_;
  Intrinsics k_;
  mutable std::mutex mutex_;  // guards bag_: rosbag::Bag reads through one file position
  mutable rosbag::Bag bag_;
  mutable Undistorter undistorter_;                                      // the camera's tables, made on the first frame
  std::map<std::string, std::pair<std::string, uint32_t>> topic_types_;  // topic -> (datatype, messages)
  std::vector<FrameEntry> entries_;
  std::vector<std::pair<ImageRef, ImageRef>> refs_;  // colour, depth of each entry
};

std::string RosbagSource::topic_list() const {
  if (topic_types_.empty()) return "the bag has no topics";
  std::string s = "the bag has ";
  for (const auto& [topic, info] : topic_types_) {
    if (s.size() > 12) s += ", ";
    s += quote_for_error(topic, 80) + " (" + quote_for_error(info.first, 80) + ", " + std::to_string(info.second) +
         " messages)";  // names from the bag: quoted, one line whatever they hold
  }
  return s;
}

Status RosbagSource::check_topic(const std::string& topic, const char* type, const char* option,
                                 const char* hint) const {
  auto it = topic_types_.find(topic);
  if (it == topic_types_.end()) return bad("no topic " + topic + " (" + option + hint + "); " + topic_list());
  if (it->second.first != type || it->second.second == 0)
    return bad("topic " + topic + " holds " + std::to_string(it->second.second) + " " +
               quote_for_error(it->second.first, 80) + " messages, not " + type + " (" + option + hint + "); " +
               topic_list());
  return ok_status();
}

Result<std::vector<StampedPath>> RosbagSource::index_images(const std::string& topic, bool depth,
                                                            std::vector<ImageRef>* refs) {
  std::vector<StampedPath> stamped;
  rosbag::View view(bag_, rosbag::TopicQuery(topic));
  for (const rosbag::MessageInstance& m : view) {
    auto read = read_message<sensor_msgs::Image>(m, RosMessageLayout::kImage);
    if (!read) return bad(topic + ": " + read.error().message);
    const auto& img = *read;
    if (!img) return bad(topic + ": a message is not a sensor_msgs/Image");
    // Decoding the first message finds an unsupported encoding at open time, not at frame N.
    if (refs->empty()) {
      const std::string label = path_ + ": " + (depth ? "depth topic " : "colour topic ") + topic;
      if (depth) {
        if (auto d = ros_depth(view_of(*img), label); !d) return d.error();
      } else if (auto c = ros_color_to_rgb(view_of(*img), label); !c) {
        return c.error();
      }
    }
    stamped.push_back({img->header.stamp.toSec(), std::to_string(refs->size())});
    refs->push_back({m.getTime(), img->header.stamp});
  }
  return stamped;
}

Status RosbagSource::open(const SourceOptions& o) {
  // rosbag_storage trusts the lengths a bag declares: the whole bag is walked first (input/rosbag_check.h).
  if (auto st = check_rosbag_file(path_); !st) {
    const std::string why = st.error().message.substr(st.error().message.rfind("ROS bag: ", 0) == 0 ? 9 : 0);
    return bad("not a readable ROS 1 bag (truncated or corrupt: " + why + ")");
  }
  try {
    bag_.open(path_, rosbag::bagmode::Read);
    for (const rosbag::ConnectionInfo* c : rosbag::View(bag_).getConnections())
      topic_types_[c->topic] = {c->datatype, 0};
    for (auto& [topic, info] : topic_types_) info.second = rosbag::View(bag_, rosbag::TopicQuery(topic)).size();

    if (auto st = check_topic(topics_.color, "sensor_msgs/Image", "--color-topic"); !st) return st;
    if (auto st = check_topic(topics_.depth, "sensor_msgs/Image", "--depth-topic"); !st) return st;
    if (o.intrinsics.empty()) {
      if (auto st =
              check_topic(topics_.camera_info, "sensor_msgs/CameraInfo", "--camera-info-topic", " or --intrinsics");
          !st)
        return st;
      rosbag::View view(bag_, rosbag::TopicQuery(topics_.camera_info));
      auto read = read_message<sensor_msgs::CameraInfo>(*view.begin(), RosMessageLayout::kCameraInfo);
      if (!read) return bad(topics_.camera_info + ": " + read.error().message);
      const auto& info = *read;
      if (!info) return bad(topics_.camera_info + ": not a sensor_msgs/CameraInfo");
      RosCameraInfo ci{info->width, info->height, info->distortion_model, info->D, {}};
      std::copy(info->K.begin(), info->K.end(), ci.K.begin());
      auto k = intrinsics_from_camera_info(ci, path_ + ": " + topics_.camera_info);
      if (!k) return k.error();
      k_ = *k;
    }
    if (o.depth_scale) {
      if (!(*o.depth_scale > 0) || !std::isfinite(*o.depth_scale))
        return make_error(ErrorCode::kInvalidArgument, "--depth-scale must be positive");
      k_.depth_scale = *o.depth_scale;
    } else {
      k_.depth_scale = 1000.0;  // 16UC1 depth is millimetres (REP 118)
    }

    std::vector<ImageRef> color_refs, depth_refs;
    auto colors = index_images(topics_.color, false, &color_refs);
    if (!colors) return colors.error();
    auto depths = index_images(topics_.depth, true, &depth_refs);
    if (!depths) return depths.error();
    for (const FrameEntry& e : associate(*colors, *depths, o.max_time_difference_s)) {
      const ImageRef& c = color_refs[std::stoul(e.color_path)];
      const ImageRef& d = depth_refs[std::stoul(e.depth_path)];
      refs_.emplace_back(c, d);
      entries_.push_back({stamp_label(path_, topics_.color, c.stamp), stamp_label(path_, topics_.depth, d.stamp),
                          e.color_timestamp, e.depth_timestamp});
    }
  } catch (const std::exception& e) {
    return bad(std::string("not a readable ROS 1 bag (truncated or corrupt: ") + quote_for_error(e.what(), 200) + ")");
  }
  if (entries_.empty()) {
    char limit[32];
    std::snprintf(limit, sizeof limit, "%g", o.max_time_difference_s);
    return make_error(ErrorCode::kEmpty, path_ + ": no colour image on " + topics_.color + " has a depth image on " +
                                             topics_.depth + " within " + limit + " s");
  }
  return ok_status();
}

Result<sensor_msgs::Image::ConstPtr> RosbagSource::read_image(const std::string& topic, const ImageRef& ref) const {
  rosbag::View view(bag_, rosbag::TopicQuery(topic), ref.bag_time, ref.bag_time);
  for (const rosbag::MessageInstance& m : view) {
    auto img = read_message<sensor_msgs::Image>(m, RosMessageLayout::kImage);
    if (!img) return bad(topic + ": " + img.error().message);
    if (*img && (*img)->header.stamp == ref.stamp) return sensor_msgs::Image::ConstPtr(*img);
  }
  return bad(topic + ": the message stamped " + std::to_string(ref.stamp.toSec()) + " is gone");
}

Result<RgbdFrame> RosbagSource::frame(size_t i) const {
  if (i >= entries_.size())
    return make_error(ErrorCode::kNotFound, "frame " + std::to_string(i) + " is past the end (" + path_ + " has " +
                                                std::to_string(entries_.size()) + " frames)");
  sensor_msgs::Image::ConstPtr color_msg, depth_msg;
  try {
    std::lock_guard<std::mutex> lock(mutex_);
    auto c = read_image(topics_.color, refs_[i].first);
    if (!c) return c.error();
    auto d = read_image(topics_.depth, refs_[i].second);
    if (!d) return d.error();
    color_msg = *c;
    depth_msg = *d;
  } catch (const std::exception& e) {
    return bad(std::string("frame ") + std::to_string(i) +
               " unreadable (truncated or corrupt bag: " + quote_for_error(e.what(), 200) + ")");
  }
  const FrameEntry& e = entries_[i];
  auto color = ros_color_to_rgb(view_of(*color_msg), e.color_path);
  if (!color) return color.error();
  auto depth = ros_depth(view_of(*depth_msg), e.depth_path);
  if (!depth) return depth.error();
  Intrinsics k = k_;
  if (depth->metres) k.depth_scale = 1.0;
  auto f = make_frame(*color, depth->image, k, &undistorter_);
  if (!f) return make_error(f.error().code, e.depth_path + ": " + f.error().message);
  f->timestamp = e.color_timestamp;
  f->index = static_cast<int>(i);
  f->color_path = e.color_path;
  f->depth_path = e.depth_path;
  return f;
}

}  // namespace

Result<std::unique_ptr<FrameSource>> open_rosbag_source(const std::string& path, const SourceOptions& options) {
  Intrinsics k;
  if (!options.intrinsics.empty()) {
    auto given = resolve_intrinsics(options.intrinsics);
    if (!given) return given.error();
    k = *given;
  }
  auto source = std::make_unique<RosbagSource>(path, options.rosbag, k);
  if (auto st = source->open(options); !st) return st.error();
  return std::unique_ptr<FrameSource>(std::move(source));
}

}  // namespace rgbdcast
