// ROS 1 bags as a frame source (input/rosbag_source.h), on bags written at test time from the shared TUM fr1/xyz
// frames: the bag must give the folder's frames, pixel for pixel where the encoding allows it.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <map>

#include "input/frame_source.h"
#include "input/intrinsics_io.h"
#include "input/rosbag_check.h"
#include "tests/common/test_data.h"
#include "tests/input/test_bags.h"

namespace fs = std::filesystem;

namespace rgbdcast {
namespace {

const char* kFr1 = "tum/rgbd_dataset_freiburg1_xyz";

#define REQUIRE_BAG(var, name, ...)                                \
  REQUIRE_DATA(kFr1);                                              \
  REQUIRE_BAG_WRITER();                                            \
  const test::MadeBag var = bag(name, test::BagSpec{__VA_ARGS__}); \
  ASSERT_TRUE(var.ok) << var.why_not

// One bag per spec and test binary run: writing one takes Python a second.
test::MadeBag bag(const std::string& name, const test::BagSpec& spec) {
  static const std::string dir = test::temp_dir("rosbag-source");
  static std::map<std::string, test::MadeBag> made;
  auto it = made.find(name);
  if (it == made.end()) {
    it = made.emplace(name, test::make_fr1_bag(dir, name, spec)).first;
    if (it->second.ok)
      std::printf("[ bag ] %s: %ju bytes\n", it->second.path.c_str(), std::uintmax_t(fs::file_size(it->second.path)));
  }
  return it->second;
}

std::unique_ptr<FrameSource> open_or_die(const std::string& path, const SourceOptions& o = {}) {
  auto s = open_frame_source(path, o);
  EXPECT_TRUE(s) << s.error().message;
  return s ? std::move(*s) : nullptr;
}

// Frame i of both sources: the same colour pixels, depth within tolerance_m (0: bit for bit), the same valid pixels.
void expect_same_frame(const FrameSource& folder, const FrameSource& bag, size_t i, double tolerance_m) {
  auto a = folder.frame(i);
  auto c = bag.frame(i);
  ASSERT_TRUE(a) << a.error().message;
  ASSERT_TRUE(c) << c.error().message;
  EXPECT_NEAR(c->timestamp, a->timestamp, 1e-6) << "frame " << i;
  EXPECT_EQ(c->index, int(i));
  EXPECT_EQ(cv::norm(c->color_rgb, a->color_rgb, cv::NORM_INF), 0.0) << "colour of frame " << i;
  EXPECT_LE(cv::norm(c->depth_m, a->depth_m, cv::NORM_INF), tolerance_m) << "depth of frame " << i;
  EXPECT_EQ(cv::countNonZero(c->depth_m), cv::countNonZero(a->depth_m)) << "valid depth of frame " << i;
  EXPECT_GT(cv::countNonZero(c->depth_m), 200000);
}

TEST(RosbagSource, Fr1MetreBagGivesTheFolderFramesPixelForPixel) {
  REQUIRE_BAG(b, "fr1_32f", test::BagDepth::kMetres32F, "rgb8");
  auto folder = open_or_die(test::data_path(kFr1));
  auto bagsrc = open_or_die(b.path);
  ASSERT_TRUE(folder && bagsrc);
  EXPECT_EQ(bagsrc->kind(), "rosbag");
  // 4 colour and 3 depth images: the colour image without depth within 0.02 s is dropped, as in the folder.
  ASSERT_EQ(bagsrc->size(), 3u);
  ASSERT_EQ(bagsrc->size(), folder->size());
  const Intrinsics& kb = bagsrc->intrinsics();
  const Intrinsics& kf = folder->intrinsics();
  EXPECT_EQ(kb.fx, kf.fx);
  EXPECT_EQ(kb.fy, kf.fy);
  EXPECT_EQ(kb.cx, kf.cx);
  EXPECT_EQ(kb.cy, kf.cy);
  EXPECT_EQ(kb.distortion, kf.distortion) << "fr1 needs the lens distortion from CameraInfo";
  for (size_t i = 0; i < folder->size(); ++i) {
    expect_same_frame(*folder, *bagsrc, i, 0.0);
    EXPECT_NEAR(bagsrc->entries()[i].depth_timestamp, folder->entries()[i].depth_timestamp, 1e-6);
    EXPECT_NE(bagsrc->entries()[i].color_path.find(":/camera/rgb/image_color@"), std::string::npos);
  }
}

TEST(RosbagSource, MillimetreBgrBagMatchesTheFolderToTheMillimetre) {
  REQUIRE_BAG(b, "fr1_16u_bgr", test::BagDepth::kMillimetres16U, "bgr8");
  auto folder = open_or_die(test::data_path(kFr1));
  auto bagsrc = open_or_die(b.path);
  ASSERT_TRUE(folder && bagsrc);
  ASSERT_EQ(bagsrc->size(), 3u);
  EXPECT_EQ(bagsrc->intrinsics().depth_scale, 1000.0);
  // bgr8 decodes to the same RGB; 1/5000 m rounded to the nearest millimetre is at most half a millimetre off.
  for (size_t i = 0; i < folder->size(); ++i) expect_same_frame(*folder, *bagsrc, i, 0.0005 + 1e-6);
}

TEST(RosbagSource, RawTumUnitsWithADepthScaleGiveTheFolderDepthExactly) {
  REQUIRE_BAG(b, "fr1_16u_raw", test::BagDepth::kTumRaw16U, "rgb8");
  auto folder = open_or_die(test::data_path(kFr1));
  SourceOptions o;
  o.depth_scale = 5000.0;
  auto bagsrc = open_or_die(b.path, o);
  ASSERT_TRUE(folder && bagsrc);
  expect_same_frame(*folder, *bagsrc, 0, 0.0);
}

TEST(RosbagSource, CompressedChunksGiveTheSameFrames) {
  for (const char* compression : {"bz2", "lz4"}) {
    REQUIRE_BAG(b, std::string("fr1_32f_") + compression, test::BagDepth::kMetres32F, "rgb8", true, compression);
    auto folder = open_or_die(test::data_path(kFr1));
    auto bagsrc = open_or_die(b.path);
    ASSERT_TRUE(folder && bagsrc);
    ASSERT_EQ(bagsrc->size(), 3u);
    expect_same_frame(*folder, *bagsrc, 2, 0.0);
  }
}

TEST(RosbagSource, MissingTopicNamesTheTopicsTheBagHas) {
  REQUIRE_BAG(b, "fr1_32f", test::BagDepth::kMetres32F, "rgb8");
  SourceOptions o;
  o.rosbag.depth = "/camera/depth_registered/image_raw";
  auto s = open_frame_source(b.path, o);
  ASSERT_FALSE(s);
  const std::string& m = s.error().message;
  EXPECT_EQ(s.error().code, ErrorCode::kInvalidInput);
  EXPECT_EQ(m.find('\n'), std::string::npos) << "one line";
  EXPECT_NE(m.find("no topic /camera/depth_registered/image_raw (--depth-topic)"), std::string::npos) << m;
  for (const char* t : {"/camera/rgb/image_color (sensor_msgs/Image, 4 messages)",
                        "/camera/depth/image (sensor_msgs/Image, 3 messages)",
                        "/camera/rgb/camera_info (sensor_msgs/CameraInfo, 1 messages)"})
    EXPECT_NE(m.find(t), std::string::npos) << t << " in: " << m;
  // A topic of the wrong type says so.
  o.rosbag.depth = "/camera/rgb/camera_info";
  auto w = open_frame_source(b.path, o);
  ASSERT_FALSE(w);
  EXPECT_NE(w.error().message.find("holds 1 sensor_msgs/CameraInfo messages, not sensor_msgs/Image"), std::string::npos)
      << w.error().message;
}

TEST(RosbagSource, WithoutCameraInfoItAsksForIntrinsicsAndTakesThem) {
  REQUIRE_BAG(b, "fr1_32f_noinfo", test::BagDepth::kMetres32F, "rgb8", false);
  auto s = open_frame_source(b.path, {});
  ASSERT_FALSE(s);
  EXPECT_NE(s.error().message.find("no topic /camera/rgb/camera_info (--camera-info-topic or --intrinsics)"),
            std::string::npos)
      << s.error().message;
  SourceOptions o;
  o.intrinsics = "fr1";
  auto bagsrc = open_or_die(b.path, o);
  auto folder = open_or_die(test::data_path(kFr1));
  ASSERT_TRUE(bagsrc && folder);
  expect_same_frame(*folder, *bagsrc, 1, 0.0);
}

TEST(RosbagSource, UnsupportedEncodingFailsAtOpenNamingIt) {
  REQUIRE_BAG(b, "fr1_yuv", test::BagDepth::kMetres32F, "yuv422");
  auto s = open_frame_source(b.path, {});
  ASSERT_FALSE(s);
  EXPECT_EQ(s.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(s.error().message.find("colour encoding \"yuv422\" is not supported (rgb8, bgr8 or mono8)"),
            std::string::npos)
      << s.error().message;
}

TEST(RosbagSource, TruncatedOrForeignFilesGiveOneLine) {
  REQUIRE_BAG(b, "fr1_32f", test::BagDepth::kMetres32F, "rgb8");
  const std::string dir = test::temp_dir("rosbag-truncated");
  const auto size = fs::file_size(b.path);
  for (double keep : {0.5, 0.99}) {
    const std::string cut = dir + "/cut.bag";
    fs::copy_file(b.path, cut, fs::copy_options::overwrite_existing);
    fs::resize_file(cut, std::uintmax_t(size * keep));
    auto s = open_frame_source(cut, {});
    ASSERT_FALSE(s) << "kept " << keep;
    EXPECT_EQ(s.error().code, ErrorCode::kInvalidInput);
    EXPECT_NE(s.error().message.find("not a readable ROS 1 bag (truncated or corrupt"), std::string::npos)
        << s.error().message;
    EXPECT_EQ(s.error().message.find('\n'), std::string::npos);
  }
  std::ofstream(dir + "/text.bag") << "not a bag\n";
  auto t = open_frame_source(dir + "/text.bag", {});
  ASSERT_FALSE(t);
  EXPECT_NE(t.error().message.find("not a readable ROS 1 bag"), std::string::npos) << t.error().message;
}

// rosbag_storage trusts a bag's declared lengths (the fuzz target found a heap over-read in ros::Header::parse on a
// connection header whose field claims more bytes than the record holds): input/rosbag_check.h walks the bag first.
// Each case is one lie written into a real bag; each is refused in one line before rosbag opens the file.
namespace hostile {
std::uint32_t u32(const std::string& b, size_t at) {
  std::uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | std::uint8_t(b[at + i]);
  return v;
}
void put32(std::string* b, size_t at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) (*b)[at + i] = char((v >> (8 * i)) & 0xff);
}
// The offset of field `name`'s value in the header of the record at `at` (npos when absent).
size_t field(const std::string& b, size_t at, const std::string& name) {
  const size_t end = at + 4 + u32(b, at);
  for (size_t i = at + 4; i + 4 <= end;) {
    const size_t len = u32(b, i);
    if (b.compare(i + 4, name.size() + 1, name + "=") == 0) return i + 4 + name.size() + 1;
    i += 4 + len;
  }
  return std::string::npos;
}
size_t data_len_at(const std::string& b, size_t at) { return at + 4 + u32(b, at); }
size_t next(const std::string& b, size_t at) { return data_len_at(b, at) + 4 + u32(b, data_len_at(b, at)); }
}  // namespace hostile

TEST(RosbagSource, LyingLengthsAreRefusedBeforeRosbagReadsThem) {
  REQUIRE_BAG(b, "fr1_32f", test::BagDepth::kMetres32F, "rgb8");
  using namespace hostile;
  std::ifstream in(b.path, std::ios::binary);
  const std::string bag((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t header = 13, chunk = next(bag, header);
  ASSERT_NE(field(bag, header, "index_pos"), std::string::npos);
  const size_t index_pos = u32(bag, field(bag, header, "index_pos"));  // below 4 GiB here
  ASSERT_EQ(bag.compare(field(bag, chunk, "compression"), 4, "none"), 0);
  const size_t index_record = next(bag, chunk);  // the first index record after the first chunk
  ASSERT_EQ(bag[field(bag, index_record, "op")], 4);

  struct Case {
    std::string what, expect;
    std::function<void(std::string*)> lie;
  };
  const std::vector<Case> cases = {
      {"a connection header field longer than its record (the fuzz find)", "a field claims",
       [&](std::string* x) { put32(x, data_len_at(*x, index_pos) + 4, u32(*x, data_len_at(*x, index_pos)) + 100); }},
      {"a record header longer than the file", "the header claims",
       [&](std::string* x) { put32(x, index_pos, 0x00fffff0); }},
      {"record data longer than the file", "the data claims",
       [&](std::string* x) { put32(x, data_len_at(*x, index_pos), 0x7ffffff0); }},
      {"index_pos inside a record", "is not a record's start",
       [&](std::string* x) { put32(x, field(*x, header, "index_pos"), std::uint32_t(index_pos + 1)); }},
      {"a 4 GiB chunk", "at most 256 MiB", [&](std::string* x) { put32(x, field(*x, chunk, "size"), 0xfffffff0); }},
      {"an uncompressed chunk whose size is not its data", "is not its data length",
       [&](std::string* x) { put32(x, field(*x, chunk, "size"), u32(*x, field(*x, chunk, "size")) - 1); }},
      {"an index entry past its chunk", "not a message of its connection",
       [&](std::string* x) { put32(x, data_len_at(*x, index_record) + 4 + 8, 0x00ffffff); }},
      {"one more connection than the index holds", "fewer than conn_count",
       [&](std::string* x) { put32(x, field(*x, header, "conn_count"), 1000); }},
  };
  const std::string dir = test::temp_dir("rosbag-lies");
  for (const Case& c : cases) {
    std::string x = bag;
    c.lie(&x);
    ASSERT_NE(x, bag) << c.what;
    const std::string path = dir + "/lie.bag";
    std::ofstream(path, std::ios::binary | std::ios::trunc) << x;
    auto s = open_frame_source(path, {});
    ASSERT_FALSE(s) << c.what;
    EXPECT_EQ(s.error().code, ErrorCode::kInvalidInput) << c.what;
    EXPECT_NE(s.error().message.find("not a readable ROS 1 bag (truncated or corrupt: record at byte"),
              std::string::npos)
        << c.what << ": " << s.error().message;
    EXPECT_NE(s.error().message.find(c.expect), std::string::npos) << c.what << ": " << s.error().message;
    EXPECT_EQ(s.error().message.find('\n'), std::string::npos) << c.what;
    std::printf("[ lie ] %s -> %s\n", c.what.c_str(),
                s.error().message.substr(s.error().message.find("record at")).c_str());
  }
}

// A compressed chunk that claims more than it holds: bz2 output is grown as it arrives, so a claimed 250 MiB costs
// what the data really decompresses to; lz4 is refused when the claim exceeds 256 bytes per byte of data.
TEST(RosbagSource, CompressedChunksThatClaimMoreAreRefusedWithoutAllocatingTheClaim) {
  using namespace hostile;
  for (const char* compression : {"bz2", "lz4"}) {
    REQUIRE_BAG(b, std::string("fr1_32f_") + compression, test::BagDepth::kMetres32F, "rgb8", true, compression);
    std::ifstream in(b.path, std::ios::binary);
    std::string bag((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const size_t chunk = next(bag, 13);
    ASSERT_EQ(bag.compare(field(bag, chunk, "compression"), 3, compression), 0);
    for (std::uint32_t claim : {250u << 20, u32(bag, field(bag, chunk, "size")) + 1}) {
      std::string x = bag;
      put32(&x, field(x, chunk, "size"), claim);
      const std::string path = test::temp_dir("rosbag-claims") + "/claim.bag";
      std::ofstream(path, std::ios::binary | std::ios::trunc) << x;
      auto s = open_frame_source(path, {});
      ASSERT_FALSE(s) << compression << " claiming " << claim;
      EXPECT_NE(s.error().message.find("chunk does not decompress to its size " + std::to_string(claim)),
                std::string::npos)
          << s.error().message;
    }
  }
}

// The serialized layout walk in front of ROS deserialization (check_ros_message), on hand-built messages: a whole
// Image and CameraInfo pass; cut anywhere inside, or with an array that claims more than follows, they fail naming
// the field.
TEST(RosbagSource, MessageLayoutsAreWalkedBeforeDeserializing) {
  auto u32 = [](std::string* s, std::uint32_t v) {
    for (int i = 0; i < 4; ++i) s->push_back(static_cast<char>((v >> (8 * i)) & 0xff));
  };
  auto str = [&u32](std::string* s, const std::string& v) {
    u32(s, static_cast<std::uint32_t>(v.size()));
    *s += v;
  };
  std::string image;
  u32(&image, 7), u32(&image, 1), u32(&image, 2), str(&image, "camera");  // header
  u32(&image, 2), u32(&image, 3), str(&image, "rgb8"), image.push_back('\0'), u32(&image, 9);
  const size_t data_len_at = image.size();
  str(&image, std::string(18, 'x'));
  auto check = [](RosMessageLayout l, const std::string& b) {
    return check_ros_message(l, reinterpret_cast<const std::uint8_t*>(b.data()), b.size());
  };
  EXPECT_TRUE(check(RosMessageLayout::kImage, image).ok());
  EXPECT_TRUE(check(RosMessageLayout::kImage, image + "trailing").ok());  // ROS allows trailing bytes
  for (size_t cut = 0; cut < image.size(); ++cut) {
    auto st = check(RosMessageLayout::kImage, image.substr(0, cut));
    ASSERT_FALSE(st.ok()) << cut;
    EXPECT_EQ(st.error().code, ErrorCode::kInvalidInput);
    EXPECT_EQ(st.error().message.find('\n'), std::string::npos);
  }
  std::string lie = image;
  lie[data_len_at + 3] = '\x7f';  // data claims 2^31 + 18 bytes
  auto st = check(RosMessageLayout::kImage, lie);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("'data' claims 2130706450 bytes"), std::string::npos) << st.error().message;

  std::string info;
  u32(&info, 0), u32(&info, 0), u32(&info, 0), str(&info, "");
  u32(&info, 640), u32(&info, 480), str(&info, "plumb_bob");
  const size_t d_at = info.size();
  u32(&info, 5), info += std::string(5 * 8 + (9 + 9 + 12) * 8, '\0');
  u32(&info, 0), u32(&info, 0), info += std::string(17, '\0');
  EXPECT_TRUE(check(RosMessageLayout::kCameraInfo, info).ok());
  EXPECT_FALSE(check(RosMessageLayout::kCameraInfo, info.substr(0, info.size() - 1)).ok());
  std::string many = info;
  many[d_at + 3] = '\x20';  // D claims 2^29 + 5 doubles
  st = check(RosMessageLayout::kCameraInfo, many);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("'D' claims 4294967336 bytes"), std::string::npos) << st.error().message;
}

// Fuzz find (rosbag target, harden4, 22,857 execs): a 30,949-byte bag whose colour image declares 3,275,720,622
// bytes of data; ROS resized the vector to that before finding the bytes missing (libFuzzer: out-of-memory). It is
// refused now, naming the field, and the process's peak RSS does not move by the claim.
TEST(RosbagSource, AnImageThatClaimsGigabytesIsRefusedWithoutAllocatingThem) {
  const std::string find =
      std::string(RGBDCAST_SOURCE_DIR) + "/tests/fuzz/crashes/rosbag/rosbag_oom_image_data_length_claims_3_gb";
  ASSERT_TRUE(fs::exists(find)) << find;
  const std::string path = test::temp_dir("rosbag-oom") + "/find.bag";  // a bag is known by its extension
  fs::copy_file(find, path, fs::copy_options::overwrite_existing);
  auto hwm_kib = [] {
    std::ifstream in("/proc/self/status");
    std::string line;
    while (std::getline(in, line))
      if (line.rfind("VmHWM:", 0) == 0) return std::stol(line.substr(6));
    return 0L;
  };
  const long before = hwm_kib();
  auto s = open_frame_source(path, {});
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(s.error().message.find("sensor_msgs/Image message of"), std::string::npos) << s.error().message;
  EXPECT_NE(s.error().message.find("'data' claims 3275720622 bytes"), std::string::npos) << s.error().message;
  EXPECT_EQ(s.error().message.find('\n'), std::string::npos);
  EXPECT_LT(hwm_kib() - before, 256L << 10);  // the claim was 3.1 GiB
}

TEST(RosbagSource, PairsOnlyWithinTheTimeLimit) {
  REQUIRE_BAG(b, "fr1_32f", test::BagDepth::kMetres32F, "rgb8");
  SourceOptions o;
  o.max_time_difference_s = 1e-4;  // fr1's colour and depth stamps are milliseconds apart
  auto s = open_frame_source(b.path, o);
  ASSERT_FALSE(s);
  EXPECT_EQ(s.error().code, ErrorCode::kEmpty);
  auto past = open_or_die(b.path);
  ASSERT_TRUE(past);
  auto f = past->frame(3);
  ASSERT_FALSE(f);
  EXPECT_EQ(f.error().code, ErrorCode::kNotFound);
}

}  // namespace
}  // namespace rgbdcast
