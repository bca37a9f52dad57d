#pragma once
// Sources of RGB-D frames: TUM sequences, Redwood/Open3D and ICL-NUIM folders, a single PNG pair, an organized PCD,
// a ROS 1 bag.
// Frame N of a TUM sequence is the N-th rgb/depth pair associated by nearest timestamp (TUM's associate.py).
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "input/depth_encoding.h"
#include "input/frame.h"
#include "scene/result.h"

namespace rgbdcast {

// The topics of a ROS 1 bag; the defaults are those of openni_launch recordings and the TUM benchmark's bags.
struct RosbagTopics {
  std::string color = "/camera/rgb/image_color";
  std::string depth = "/camera/depth/image";
  std::string camera_info = "/camera/rgb/camera_info";
};

struct SourceOptions {
  std::string
      intrinsics;  // a preset, a JSON or a 3x3 matrix .txt path (intrinsics_io.h); empty = guessed from the source
  std::optional<double> depth_scale;                     // raw units per metre; overrides the intrinsics' value
  DepthEncoding depth_encoding = DepthEncoding::kPng16;  // of depth image files (not of PCDs and bags)
  std::string depth_path;                                // for a single colour image: its depth PNG
  std::string associations_path;  // TUM: read pairs from this file instead of associating rgb.txt/depth.txt
  double max_time_difference_s = 0.02;
  RosbagTopics rosbag;  // for a .bag file
};

struct FrameEntry {
  std::string color_path, depth_path;  // absolute
  double color_timestamp = 0.0, depth_timestamp = 0.0;
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  virtual std::string kind() const = 0;  // "tum", "redwood", "pair", "pcd", "rosbag"
  virtual size_t size() const = 0;
  virtual const Intrinsics& intrinsics() const = 0;  // as given, with distortion
  // Loads, validates and undistorts frame i. Errors: kNotFound (index past the end, missing file),
  // kInvalidInput (corrupt image, depth not 16-bit, colour and depth of different sizes).
  virtual Result<RgbdFrame> frame(size_t i) const = 0;
  virtual const std::vector<FrameEntry>& entries() const = 0;
  virtual std::string root() const = 0;  // the folder or file it was opened from
};

// Opens `path`: a folder with rgb.txt and depth.txt (TUM), a folder with color/ and depth/ (Redwood/Open3D,
// ICL-NUIM), a colour image with options.depth_path, a .pcd file, or a .bag file (ROS 1; see rosbag_source.h;
// kUnavailable when built without librosbag-storage-dev).
Result<std::unique_ptr<FrameSource>> open_frame_source(const std::string& path, const SourceOptions& options);

// TUM's associate.py: pairs each rgb stamp with the nearest unused depth stamp within max_difference, greedily by
// time difference; the result is sorted by rgb time. Inputs are (timestamp, path) lists.
struct StampedPath {
  double timestamp;
  std::string path;
};
std::vector<FrameEntry> associate(const std::vector<StampedPath>& rgb, const std::vector<StampedPath>& depth,
                                  double max_difference_s);
// Reads a TUM list file (rgb.txt / depth.txt): "timestamp path" lines, '#' comments.
Result<std::vector<StampedPath>> read_tum_list(const std::string& path);

// The largest frame the decoders accept. The size is read from the PNG/JPEG header and checked before decoding: a
// 100 kB PNG can claim 16384x16384 and decode to 1 GB, and the reduction's cost grows with the pixels. The default
// is what the service takes from a client (1920x1080, either orientation; PNG or JPEG only); local dataset files
// use local_files() (kMaxImageSize per side, any format OpenCV reads: the PCL data set's TIFFs).
struct FrameLimits {
  int max_long_side_px = 1920;
  int max_short_side_px = 1080;
  bool png_jpeg_only = true;
  static FrameLimits local_files() { return {8192, 8192, false}; }
};

// Decodes and validates images (the service's uploads; untrusted). Colour: an 8-bit PNG or JPEG (any 8-bit image
// OpenCV reads with local_files()), grey and RGBA converted; depth: a 16-bit single-channel PNG. Errors are
// kInvalidInput naming `what` and the problem (too large: the size and the limit), one line.
Result<cv::Mat> decode_color(const std::vector<unsigned char>& bytes, const std::string& what,
                             const FrameLimits& limits = {});
Result<cv::Mat> decode_depth16(const std::vector<unsigned char>& bytes, const std::string& what,
                               const FrameLimits& limits = {});
// The undistortion tables of the last camera seen. Every frame of a sequence (and every upload from one robot) has
// the same camera, so the owner of a stream of frames (a FrameSource, a bench) keeps one instead of rebuilding the
// tables per frame (initUndistortRectifyMap: a few ms at 640x480). Thread-safe; the tables are never modified once
// built, so frames being undistorted keep theirs while another camera's are made.
class Undistorter {
 public:
  struct Maps {
    cv::Mat linear_xy, linear_frac, nearest_xy;  // fixed-point tables: colour bilinear, depth nearest
  };
  Undistorter();
  ~Undistorter();
  Maps maps(const Intrinsics& k);  // the camera's tables, built when it differs from the last one

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// Builds a frame from decoded images: checks sizes against each other and the intrinsics, converts depth to metres,
// undistorts (through `undistorter`'s tables; without one, tables made for this frame). color is RGB CV_8UC3,
// depth_raw CV_16UC1 in units of intrinsics.depth_scale (or CV_32FC1 with depth_scale 1: metres, 0 = no reading).
Result<RgbdFrame> make_frame(const cv::Mat& color_rgb, const cv::Mat& depth_raw, const Intrinsics& intrinsics,
                             Undistorter* undistorter = nullptr);

}  // namespace rgbdcast
