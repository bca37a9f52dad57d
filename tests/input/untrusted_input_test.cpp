// The input parsers against hostile bytes: intrinsics JSON from memory, frame size caps read from the
// image header before decoding, the PCD header check in front of PCL.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "input/frame_source.h"
#include "input/intrinsics_io.h"
#include "input/pcd_header.h"
#include "input/pcd_source.h"
#include "tests/common/test_data.h"

namespace rgbdcast {
namespace {

std::vector<unsigned char> png_of(const cv::Mat& m) {
  std::vector<unsigned char> out;
  cv::imencode(".png", m, out);
  return out;
}

// A PNG whose IHDR is patched to claim w x h (the data stays that of a small image).
std::vector<unsigned char> png_claiming(int w, int h) {
  auto b = png_of(cv::Mat(8, 8, CV_16UC1, cv::Scalar(5000)));
  for (int i = 0; i < 4; ++i) {
    b[16 + i] = static_cast<unsigned char>(static_cast<unsigned>(w) >> (24 - 8 * i));
    b[20 + i] = static_cast<unsigned char>(static_cast<unsigned>(h) >> (24 - 8 * i));
  }
  return b;
}

TEST(UntrustedIntrinsics, ParsesFromMemoryWithoutPaths) {
  auto k = parse_intrinsics_json(R"({"fx": 517.3, "fy": 516.5, "cx": 318.6, "cy": 255.3, "width": 640,
                                     "height": 480, "distortion": [0.2624, -0.9531, -0.0054, 0.0026, 1.1633],
                                     "depth_scale": 5000})");
  ASSERT_TRUE(k) << k.error().message;
  EXPECT_DOUBLE_EQ(k->fx, 517.3);
  EXPECT_DOUBLE_EQ(k->distortion[4], 1.1633);
  EXPECT_DOUBLE_EQ(k->depth_scale, 5000);
  EXPECT_EQ(k->name, "intrinsics");
  auto o3d = parse_intrinsics_json(
      R"({"width": 640, "height": 480, "intrinsic_matrix": [525, 0, 0, 0, 525, 0, 319.5, 239.5, 1]})");
  ASSERT_TRUE(o3d);
  EXPECT_DOUBLE_EQ(o3d->cy, 239.5);
}

TEST(UntrustedIntrinsics, RejectsHostileJsonWithOneLineErrors) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", "not a JSON object"},
      {"[1, 2]", "not a JSON object"},
      {R"({"fx": -517, "fy": 516, "cx": 1, "cy": 1, "width": 640, "height": 480})", "finite and positive"},
      {R"({"fx": 517, "fy": -516, "cx": 1, "cy": 1, "width": 640, "height": 480})", "finite and positive"},
      {R"({"fx": 1e400, "fy": 516, "cx": 1, "cy": 1, "width": 640, "height": 480})", "not a JSON object"},
      {R"({"fx": 5, "fy": 5, "cx": 1, "cy": 1, "width": 4294967936, "height": 480})", "between 1 and 16384"},
      {R"({"fx": 5, "fy": 5, "cx": 1, "cy": 1, "width": 18446744073709551615, "height": 480})", "between 1 and 16384"},
      {R"({"fx": 5, "fy": 5, "cx": 1, "cy": 1, "width": 640.5, "height": 480})", "must be integers"},
      {R"({"fx": 5, "fy": 5, "cx": 1, "cy": 1, "width": 64, "height": 48, "distortion": [1,2,3,4,5,6]})", "up to 5"},
      {R"({"fx": 5, "fy": 5, "cx": 1, "cy": 1, "width": 64, "height": 48, "depth_scale": 0})", "positive"},
      {std::string(20000, '[') + std::string(20000, ']'), "nested deeper than 16 levels"},
      {std::string((1 << 20) + 1, ' '), "over the limit of 1048576"},
  };
  for (const auto& [text, needle] : cases) {
    auto k = parse_intrinsics_json(text, "intrinsics");
    ASSERT_FALSE(k) << text.substr(0, 80);
    EXPECT_EQ(k.error().code, ErrorCode::kInvalidInput);
    EXPECT_NE(k.error().message.find(needle), std::string::npos) << k.error().message;
    EXPECT_EQ(k.error().message.rfind("intrinsics: ", 0), 0u) << k.error().message;
    EXPECT_EQ(k.error().message.find('/'), std::string::npos) << "no path in: " << k.error().message;
  }
}

TEST(UntrustedFrames, SizeIsCheckedFromTheHeaderBeforeDecoding) {
  // The probe's 4096x4096 upload, and 16384x16384: refused by the header, whatever the data.
  for (auto [w, h] : {std::pair{4096, 4096}, std::pair{16384, 16384}, std::pair{1921, 1080}, std::pair{1920, 1081}}) {
    auto d = decode_depth16(png_claiming(w, h), "depth");
    ASSERT_FALSE(d) << w << "x" << h;
    EXPECT_EQ(d.error().message,
              "depth: " + std::to_string(w) + "x" + std::to_string(h) + " is over the frame limit of 1920x1080");
  }
  rusage before{}, after{};
  getrusage(RUSAGE_SELF, &before);
  for (int i = 0; i < 20; ++i) (void)decode_color(png_claiming(16384, 16384), "color");
  getrusage(RUSAGE_SELF, &after);
  EXPECT_LT(after.ru_maxrss - before.ru_maxrss, 64 * 1024) << "KiB of peak RSS for 20 refused frames";
  // At the limit, both orientations decode.
  const cv::Mat full(1080, 1920, CV_16UC1, cv::Scalar(5000)), portrait(1920, 1080, CV_16UC1, cv::Scalar(5000));
  auto a = decode_depth16(png_of(full), "depth");
  ASSERT_TRUE(a) << a.error().message;
  EXPECT_EQ(a->cols, 1920);
  EXPECT_TRUE(decode_depth16(png_of(portrait), "depth"));
  // Other formats are refused for uploads, read for local files.
  std::vector<unsigned char> bmp;
  cv::imencode(".bmp", cv::Mat(8, 8, CV_8UC3, cv::Scalar(1, 2, 3)), bmp);
  auto refused = decode_color(bmp, "color");
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().message.find("not a readable PNG or JPEG"), std::string::npos);
  EXPECT_TRUE(decode_color(bmp, "color", FrameLimits::local_files()));
  // A configured limit.
  FrameLimits small{640, 480, true};
  EXPECT_FALSE(decode_depth16(png_of(full), "depth", small));
}

std::string pcd_header(const std::string& width, const std::string& height, const std::string& points,
                       const std::string& data) {
  return "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z rgba\nSIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\nWIDTH " + width +
         "\nHEIGHT " + height + "\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + points + "\nDATA " + data + "\n";
}

Result<PcdHeader> check(const std::string& bytes) {
  return check_pcd_header(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
}

TEST(UntrustedPcd, HeaderMustMatchTheBytesPresent) {
  const std::string body(16 * 16, '\0');  // 4x4 points of 16 bytes
  auto ok = check(pcd_header("4", "4", "16", "binary") + body);
  ASSERT_TRUE(ok) << ok.error().message;
  EXPECT_EQ(ok->point_bytes, 16u);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {pcd_header("8192", "8192", "67108864", "ascii") + "0 0 0 0\n", "ascii data too short"},  // 64 M points claimed
      {pcd_header("8192", "8192", "67108864", "binary") + body,
       "binary data holds 256 bytes, the header needs 1073741824"},
      {pcd_header("4", "4", "17", "binary") + body, "POINTS is not WIDTH x HEIGHT"},
      {pcd_header("9000", "2", "18000", "binary"), "2..8192"},
      {pcd_header("4", "1", "4", "binary"), "2..8192"},
      {pcd_header("-4", "4", "16", "binary"), "2..8192"},
      {pcd_header("4", "4", "16", "binary_compressed") + std::string("\x10\0\0\0\x40\0\0\0", 8), "cut short"},
      {pcd_header("4", "4", "16", "binary_compressed") + std::string("\x00\0\0\0\x41\0\0\0", 8), "uncompressed size"},
      {pcd_header("4", "4", "16", "lzma") + body, "DATA must be"},
      {"# nothing but a comment\n", "no DATA line"},
      {"FIELDS x\nSIZE 4 4\nTYPE F\nWIDTH 2\nHEIGHT 2\nDATA ascii\n", "different lengths"},
      {"FIELDS x\nSIZE 3\nTYPE F\nWIDTH 2\nHEIGHT 2\nDATA ascii\n", "SIZE of x"},
      {"FIELDS x\nFIELDS y\n", "appears twice"},
      // fuzz_pcd's first find: PCL 1.13 dereferences NULL on a header whose VERSION line is misspelt.
      {"# .PCD v0.7\nV\xf3RSION 0.7\nFIELDS x\n", "unknown header line 'V?RSION'"},
      // Its second: a use-after-free in PCL on fields without x and a COUNT of 2.
      {"FIELDS JJx y z rgba\nSIZE 4 4 4 4\nTYPE F F F U\nCOUNT 2 1 1 1\nWIDTH 4\nHEIGHT 3\nDATA binary\n" +
           std::string(240, '\0'),
       "field JJx must have COUNT 1"},
      {"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 4\nHEIGHT 3\nDATA binary\n" + std::string(144, '\0'),
       "a field rgb or rgba is required"},
      {"FIELDS x y x rgb\nSIZE 4 4 4 4\nTYPE F F F U\nWIDTH 2\nHEIGHT 2\nDATA ascii\n", "field x appears twice"},
      {"FIELDS x y z rgb\nSIZE 8 4 4 4\nTYPE F F F U\nWIDTH 2\nHEIGHT 2\nDATA ascii\n", "x must be a 4-byte float"},
  };
  for (const auto& [bytes, needle] : cases) {
    auto r = check(bytes);
    ASSERT_FALSE(r) << needle;
    EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput);
    EXPECT_NE(r.error().message.find(needle), std::string::npos) << r.error().message;
  }
}

TEST(UntrustedPcd, FilesPclWritesPassTheCheck) {
  // The seeds of fuzz_pcd: a 4x3 cloud (one NaN point) written by PCL in its three encodings.
  for (const char* name : {"ascii", "binary", "binary_compressed"}) {
    std::ifstream in(std::string(RGBDCAST_SOURCE_DIR) + "/fuzz/corpus/pcd/" + name + ".pcd", std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    auto h = check(bytes);
    ASSERT_TRUE(h) << name << ": " << h.error().message;
    EXPECT_EQ(h->width * h->height, 12);
    EXPECT_EQ(h->data, name);
  }
  // fuzz_pcd's third find: PCL 1.13 segfaults on an ASCII body of short and non-numeric lines.
  const std::string head = "FIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F U\nWIDTH 2\nHEIGHT 2\nDATA ascii\n";
  EXPECT_NE(check(head + "0 0 1 4278\n0 0 1\n0 0 1 5\n0 0 1 5\n").error().message.find("line 2 holds 3 values, not 4"),
            std::string::npos);
  EXPECT_NE(check(head + "0 0 1 4278\np 0 1 5\n0 0 1 5\n0 0 1 5\n").error().message.find("not a number"),
            std::string::npos);
  EXPECT_NE(
      check(head + "0.25 0.25 1.25 4278\n0.25 0.25 1.25 5\n0.25 0.25 1.25 5\n").error().message.find("holds 3 points"),
      std::string::npos);
  EXPECT_TRUE(check(head + "0 0 1 4278\nnan nan nan 5\n0 0 1 5\n0 0 1 5\n"));
  EXPECT_NE(check("VIEWPOINT 0 0 0 1 0\xc0 0 0\n" + head).error().message.find("VIEWPOINT must be 7 numbers"),
            std::string::npos);
  EXPECT_NE(check("\n" + head).error().message.find("blank or indented line"), std::string::npos);
  // Its fourth: PCL reads on after DATA while lines look like header lines, and overflows when they re-define the
  // fields. Binary data that begins "# .7\nFIELDS x" is refused.
  const std::string bin_head = "FIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F U\nWIDTH 2\nHEIGHT 2\nDATA binary\n";
  std::string body = "# .7\nFIELDS x y";
  body.resize(64, '\x01');
  EXPECT_NE(check(bin_head + body).error().message.find("starts like a header line"), std::string::npos);
  body[5] = 'X';  // "# .7\nXIELDS": the walk stops at a line that is no key, as PCL's does
  EXPECT_TRUE(check(bin_head + body));
}

TEST(UntrustedPcd, RealKinectFramesPassTheCheck) {
  const char* rel = "pcl_kinect_organized/pcd/frame_20121214T142255.814212.pcd";
  REQUIRE_DATA(rel);
  std::ifstream in(test::data_path(rel), std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto h = check(bytes);
  ASSERT_TRUE(h) << h.error().message;
  EXPECT_EQ(h->width, 640);
  EXPECT_EQ(h->height, 480);
  EXPECT_EQ(h->point_bytes, 16u);
  EXPECT_EQ(h->data, "binary_compressed");
}

}  // namespace
}  // namespace rgbdcast
