// pipeline/frame_defaults.h: the default budget is min(40 kB, a quarter of the frame's JPEG90+PNG16 payload), and the
// GLB the defaults give is at most a quarter of that payload, on real frames where each side of the min
// applies: the PCL Kinect PCDs (JPEG90+PNG16 about 130 kB: a quarter) and TUM fr1/xyz and ICL-NUIM (over 160 kB: 40
// kB).
#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>

#include "gltf/gltf_io.h"
#include "input/frame_source.h"
#include "pipeline/frame_defaults.h"
#include "pipeline/frame_scene.h"
#include "tests/common/test_data.h"

namespace rgbdcast {
namespace {

struct Case {
  std::string path, intrinsics;
  bool quarter_applies;  // the payload is under 160 kB, so the budget is its quarter, not 40 kB
};

const Case kCases[] = {
    {"pcl_kinect_organized/pcd/frame_20121214T142255.814212.pcd", "kinect", true},
    {"pcl_kinect_organized/pcd/frame_20121214T142256.068683.pcd", "kinect", true},
    {"pcl_kinect_organized/pcd/frame_20121214T142256.332395.pcd", "kinect", true},
    {"tum/rgbd_dataset_freiburg1_xyz", "fr1", false},
    {"icl_nuim_livingroom", "", false},
};

// Frame 0 of a shared capture.
Result<RgbdFrame> first_frame(const std::string& path, const std::string& intrinsics) {
  SourceOptions so;
  so.intrinsics = intrinsics;
  auto src = open_frame_source(test::data_path(path), so);
  if (!src) return src.error();
  return (*src)->frame(0);
}

TEST(FrameDefaults, TheDefaultBudgetKeepsTheGlbUnderAQuarterOfJpeg90Png16) {
  EXPECT_EQ(kDefaultPreset, Preset::kRealtime);
  EXPECT_EQ(default_geometry_codec(Preset::kRealtime), GeometryCodec::kDraco);
  EXPECT_EQ(default_geometry_codec(Preset::kPaper), GeometryCodec::kMeshopt);
  for (const Case& c : kCases) {
    REQUIRE_DATA(c.path);
    auto frame = first_frame(c.path, c.intrinsics);
    ASSERT_TRUE(frame) << c.path << ": " << frame.error().message;
    auto payload = encode_jpeg_png16(*frame, 90);
    ASSERT_TRUE(payload) << payload.error().message;
    auto budget = default_budget_kb(*frame);
    ASSERT_TRUE(budget) << budget.error().message;
    const double quarter_kb = payload->bytes() / 4000.0;
    EXPECT_DOUBLE_EQ(*budget, std::min(kDefaultBudgetKb, quarter_kb)) << c.path;
    EXPECT_EQ(*budget < kDefaultBudgetKb, c.quarter_applies) << c.path << ": payload " << payload->bytes();

    // The defaults, as reduce and the service build them: the payload's share is estimated inside the frame ->
    // scene function. It gives the budget above, and the same file as that budget given explicitly.
    FrameReductionOptions o;
    o.params = reduction_preset(kDefaultPreset);
    o.glb.geometry_codec = default_geometry_codec(kDefaultPreset);
    o.budget_kb = kDefaultBudgetKb;
    o.budget_within_payload_share = true;
    FrameReductionOptions given = o;
    given.budget_within_payload_share = false;
    given.budget_kb = *budget;
    auto glb_of = [&](const FrameReductionOptions& options, double* budget_bytes) -> Result<std::vector<std::uint8_t>> {
      auto textured = reduce_and_texture(*frame, options);
      if (!textured) return textured.error();
      *budget_bytes = textured->budget.budget_bytes;
      const GlbWriteOptions w = write_options(*textured, options.glb);
      return encode_glb(frame_scene(std::move(*textured), "{}"), w);
    };
    double estimated_bytes = 0, given_bytes = 0;
    auto glb = glb_of(o, &estimated_bytes);
    ASSERT_TRUE(glb) << c.path << ": " << glb.error().message;
    auto explicit_glb = glb_of(given, &given_bytes);
    ASSERT_TRUE(explicit_glb) << c.path << ": " << explicit_glb.error().message;
    EXPECT_DOUBLE_EQ(estimated_bytes, *budget * 1000.0) << c.path;
    EXPECT_DOUBLE_EQ(given_bytes, *budget * 1000.0) << c.path;
    EXPECT_TRUE(*glb == *explicit_glb) << c.path << ": the estimated default and the same budget given differ";
    std::cout << c.path << ": JPEG90+PNG16 " << payload->bytes() << " bytes, budget " << *budget << " kB, GLB "
              << glb->size() << " bytes\n";
    EXPECT_LE(glb->size(), payload->bytes() / 4) << c.path;
  }
}

TEST(FrameDefaults, ThePayloadIsAJpegAndAPng) {
  REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz");
  auto frame = first_frame("tum/rgbd_dataset_freiburg1_xyz", "fr1");
  ASSERT_TRUE(frame) << frame.error().message;
  auto full = encode_jpeg_png16(*frame, 90);
  auto half = encode_jpeg_png16(*frame, 90, 2);
  ASSERT_TRUE(full && half);
  ASSERT_GE(full->jpeg.size(), 3u);
  EXPECT_EQ(full->jpeg[0], 0xFF);
  EXPECT_EQ(full->jpeg[1], 0xD8);
  ASSERT_GE(full->png.size(), 8u);
  EXPECT_EQ(full->png[1], 'P');
  EXPECT_EQ(full->jpeg, half->jpeg);  // the depth step leaves the colour alone
  EXPECT_LT(half->png.size(), full->png.size() / 2);
  EXPECT_FALSE(encode_jpeg_png16(*frame, 90, 0));
  EXPECT_FALSE(encode_jpeg_png16(RgbdFrame{}, 90));
}

}  // namespace
}  // namespace rgbdcast
