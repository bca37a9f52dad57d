// pipeline/frame_scene.h on the shared real captures: the realtime preset's byte budget and its coverage of the
// valid pixels at the capture pose (the decoded GLB rendered, as a receiver sees it).
#include <gtest/gtest.h>

#include <iostream>

#include <nlohmann/json.hpp>

#include "evaluation/image_metrics.h"
#include "gltf/gltf_io.h"
#include "input/frame_source.h"
#include "pipeline/frame_defaults.h"
#include "pipeline/frame_scene.h"
#include "pipeline/keyframe_glb.h"
#include "renderer/create_renderer.h"
#include "tests/common/test_data.h"
#include "tests/pipeline/realtime_frames.h"

namespace rgbdcast {
namespace {

struct SharedFrames {
  std::string path, intrinsics;
  std::vector<size_t> frames;
  std::string depth;  // for a colour image with its depth image (PNG pairs)
};

// Every shared capture; of the 120-frame excerpt, every 20th frame.
const std::vector<SharedFrames> kShared = {
    {"tum/rgbd_dataset_freiburg1_xyz", "fr1", {0, 1, 2}, ""},
    {"tum/rgbd_dataset_freiburg1_xyz_200_319", "fr1", {0, 20, 40, 60, 80, 100}, ""},
    {"tum/rgbd_dataset_freiburg3_long_office_household", "fr3", {0, 1}, ""},
    {"tum/freiburg2_desk_pair/1.png", "fr2", {0}, "tum/freiburg2_desk_pair/1_depth.png"},
    {"tum/freiburg2_desk_pair/2.png", "fr2", {0}, "tum/freiburg2_desk_pair/2_depth.png"},
    {"augmented_icl_livingroom", "", {0, 1, 2, 3, 4}, ""},
    {"icl_nuim_livingroom", "", {0, 1, 2, 3, 4}, ""},
    {"pcl_kinect_organized/pcd/frame_20121214T142255.814212.pcd", "kinect", {0}, ""},
    {"pcl_kinect_organized/pcd/frame_20121214T142256.068683.pcd", "kinect", {0}, ""},
    {"pcl_kinect_organized/pcd/frame_20121214T142256.332395.pcd", "kinect", {0}, ""},
};

using test::realtime;

template <class F>
void for_each_shared_frame(F&& f) {
  for (const auto& set : kShared) {
    REQUIRE_DATA(set.path);
    SourceOptions o;
    o.intrinsics = set.intrinsics;
    if (!set.depth.empty()) o.depth_path = test::data_path(set.depth);
    auto src = open_frame_source(test::data_path(set.path), o);
    ASSERT_TRUE(src) << set.path << ": " << src.error().message;
    for (size_t i : set.frames) {
      auto frame = (*src)->frame(i);
      ASSERT_TRUE(frame) << set.path << " " << i << ": " << frame.error().message;
      f(*frame, set.path + " frame " + std::to_string(i));
    }
  }
}

// The budget's contract on every shared frame: within +-10 % of the budget, under it when the scene needs less, or
// "over-budget" said plainly when the mesh's tolerance, its outline's collapses and the texture's scale reach their
// limits. From 20 kB up every shared frame is met: past the largest tolerance the collapses straighten the outline
// (up to 8 px) and the texture goes down to a quarter of its resolution, so the mesh's outline is no floor there.
TEST(FrameScene, BudgetMetOrReportedOnEverySharedFrame) {
  for (double kb : {20.0, 40.0, 160.0}) {
    for_each_shared_frame([&](const RgbdFrame& frame, const std::string& what) {
      auto t = reduce_and_texture(frame, realtime(kb));
      ASSERT_TRUE(t) << what << ": " << t.error().message;
      const BudgetChoice b = t->budget;
      const GlbWriteOptions glb_options = write_options(*t, realtime(kb).glb);
      auto glb = encode_glb(frame_scene(std::move(*t), "{}"), glb_options);
      ASSERT_TRUE(glb) << what;
      const double bytes = static_cast<double>(glb->size()), target = kb * 1000;
      const std::string how = what + " at " + std::to_string(int(kb)) + " kB (" + b.rule + ", tolerance " +
                              std::to_string(b.tolerance_factor) + ", collapses " + std::to_string(b.simplify_px) +
                              " px, q" + std::to_string(b.jpeg_quality) + " at " + std::to_string(b.texture_scale) +
                              ", " + std::to_string(bytes) + " bytes)";
      if (b.rule == "fits")
        EXPECT_LE(bytes, 1.1 * target) << how;
      else if (b.rule == "over-budget")
        EXPECT_GT(bytes, 1.1 * target - 1500) << how;
      else
        EXPECT_NEAR(bytes, target, 0.1 * target) << how;
      EXPECT_NE(b.rule, "over-budget") << how;
      // The outline is straightened only past the largest tolerance, and only as far as the bytes need.
      if (b.rule != "outline-capped") {
        EXPECT_EQ(b.simplify_px, reduction_preset(Preset::kRealtime).depth_mesh.simplify_px) << how;
      }
    });
  }
}

// Coverage of the valid pixels at the capture pose, the decoded GLB rendered: at least 0.99 on every shared frame,
// with no budget and at the default 40 kB (a border triangle may not drop more than 2 pixels whatever the budget,
// and the outline's vertices move a pixel outwards, over the flying pixels the filter dropped; the paper preset
// covers 0.82-0.89 of these frames at 140-890 kB). PSNR over the pixels drawn: at least 30 dB with no budget, 29 at
// 40 kB (the least, fr2's, was 29.6 when this was written).
TEST(FrameScene, CoversTheValidPixelsAtTheCapturePose) {
  auto renderer = create_renderer(BackendChoice::kAuto);
  ASSERT_TRUE(renderer) << renderer.error().message;
  Renderer& r = *renderer->renderer;
  for (double kb : {0.0, 40.0}) {
    for_each_shared_frame([&](const RgbdFrame& frame, const std::string& what) {
      auto t = reduce_and_texture(frame, realtime(kb));
      ASSERT_TRUE(t) << what << ": " << t.error().message;
      const GlbWriteOptions glb_options = write_options(*t, realtime(kb).glb);
      auto glb = encode_glb(frame_scene(std::move(*t), "{}"), glb_options);
      ASSERT_TRUE(glb) << what;
      auto scene = decode_glb(glb->data(), glb->size());
      ASSERT_TRUE(scene) << what << ": " << scene.error().message;
      auto id = r.upload(*scene);
      ASSERT_TRUE(id) << what;
      CaptureCamera cam;
      cam.intrinsics = frame.intrinsics.pinhole();
      auto img = r.render(*id, ViewCamera::from_capture(cam), RenderOptions{});
      r.release(*id);
      ASSERT_TRUE(img) << what;
      auto f = compare_views(frame.color_rgb, img->color, frame.depth_m > 0);
      ASSERT_TRUE(f) << what;
      std::cout << what << " at " << kb << " kB: coverage " << f->coverage << ", PSNR drawn " << f->psnr_db
                << " dB, all valid " << f->psnr_valid_db << " dB\n";
      EXPECT_GE(f->coverage, 0.99) << what << " at " << kb << " kB";
      EXPECT_GE(f->psnr_db, kb == 0 ? 30.0 : 29.0) << what << " at " << kb << " kB";
    });
  }
}

TEST(FrameScene, RecordsItsChoices) {
  REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz");
  auto frame = test::fr1_xyz_frame(0);
  ASSERT_TRUE(frame) << frame.error().message;
  auto t = reduce_and_texture(*frame, realtime(40));
  ASSERT_TRUE(t) << t.error().message;
  const auto j = reduction_choices(*t);
  EXPECT_EQ(j["preset"], "realtime");
  EXPECT_EQ(j["texture"], "frame");
  EXPECT_EQ(j["budget"]["budget_bytes"], 40000.0);
  EXPECT_GT(j["budget"]["jpeg_quality"].get<int>(), 0);
  EXPECT_GT(j["budget"]["simplify_px"].get<double>(), 0);
  // A budget needs the realtime preset.
  FrameReductionOptions paper;
  paper.budget_kb = 40;
  EXPECT_EQ(reduce_and_texture(*frame, paper).error().code, ErrorCode::kInvalidArgument);
}

TEST(FrameScene, ImplausibleDepthNamesTheDepthScale) {
  REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz");
  SourceOptions o;
  o.intrinsics = "fr1";
  o.depth_scale = 5;  // 5 raw units a metre instead of 5000: a median of about a kilometre
  auto src = open_frame_source(test::data_path("tum/rgbd_dataset_freiburg1_xyz"), o);
  ASSERT_TRUE(src);
  // The file source refuses such depth itself (input/depth_encoding.h) ...
  auto refused = (*src)->frame(0);
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().message.find("--depth-scale 5"), std::string::npos) << refused.error().message;
  // ... and a frame made another way (an upload) meets the reduction's median check.
  o.depth_scale = 5000;
  src = open_frame_source(test::data_path("tum/rgbd_dataset_freiburg1_xyz"), o);
  ASSERT_TRUE(src);
  auto frame = (*src)->frame(0);
  ASSERT_TRUE(frame);
  frame->depth_m *= 1000.0;
  frame->intrinsics.depth_scale = 5;
  for (Preset p : {Preset::kRealtime, Preset::kPaper}) {
    FrameReductionOptions opt;
    opt.params = reduction_preset(p);
    auto t = reduce_and_texture(*frame, opt);
    ASSERT_FALSE(t);
    EXPECT_EQ(t.error().code, ErrorCode::kInvalidInput);
    EXPECT_NE(t.error().message.find("--depth-scale"), std::string::npos) << t.error().message;
  }
}

}  // namespace
}  // namespace rgbdcast
