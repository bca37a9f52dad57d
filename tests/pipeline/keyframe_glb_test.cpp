// pipeline/keyframe_glb.h on a shared real capture: the GLB carries the caller's capture fields and the reduction's
// choices under "rgbdcast", and is the same GLB as the frame's scene written by hand with those extras.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "gltf/gltf_io.h"
#include "pipeline/frame_scene.h"
#include "pipeline/keyframe_glb.h"
#include "tests/pipeline/realtime_frames.h"

namespace rgbdcast {
namespace {

using test::realtime;

Result<TexturedFrame> reduced_fr1_frame(double budget_kb) {
  auto frame = test::fr1_xyz_frame(0);
  if (!frame) return frame.error();
  return reduce_and_texture(*frame, realtime(budget_kb));
}

TEST(KeyframeGlb, ChoicesOfABudget) {
  REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz");
  auto t = reduced_fr1_frame(30);
  ASSERT_TRUE(t) << t.error().message;
  const nlohmann::json j = reduction_choices(*t);
  EXPECT_EQ(j["preset"], "realtime");
  EXPECT_EQ(j["texture"], "frame");
  const BudgetChoice& b = t->budget;
  EXPECT_EQ(j["budget"]["budget_bytes"].get<double>(), 30000.0);
  EXPECT_EQ(j["budget"]["tolerance_factor"].get<double>(), b.tolerance_factor);
  EXPECT_EQ(j["budget"]["jpeg_quality"].get<int>(), b.jpeg_quality);
  EXPECT_EQ(j["budget"]["glb_bytes"].get<size_t>(), b.glb_bytes);
  EXPECT_EQ(j["budget"]["rule"].get<std::string>(), b.rule);
  EXPECT_EQ(j["budget"].size(), 11u);
  TexturedFrame unbudgeted = *t;
  unbudgeted.budget = BudgetChoice{};
  EXPECT_FALSE(reduction_choices(unbudgeted).contains("budget"));
}

TEST(KeyframeGlb, ExtrasHoldTheCaptureAndTheChoices) {
  REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz");
  auto t = reduced_fr1_frame(30);
  ASSERT_TRUE(t) << t.error().message;
  const nlohmann::json choices = reduction_choices(*t);
  const size_t triangles = t->node.mesh.triangle_count();
  const nlohmann::json capture = {
      {"source", "frame-0.png"}, {"frame", 0}, {"timestamp", 1305031102.175304}, {"reduction", "replaced"}};
  // The same scene written by hand: frame_scene with the extras text, encode_glb with write_options.
  nlohmann::json expected_capture = capture;
  expected_capture["reduction"] = choices;
  const std::string expected_extras = nlohmann::json{{"rgbdcast", expected_capture}}.dump();
  auto by_hand = encode_glb(frame_scene(*t, expected_extras), write_options(*t, realtime(30).glb));
  ASSERT_TRUE(by_hand) << by_hand.error().message;

  GlbStats stats;
  auto glb = encode_keyframe_glb(std::move(*t), capture, realtime(30).glb, &stats);
  ASSERT_TRUE(glb) << glb.error().message;
  EXPECT_EQ(*glb, *by_hand);
  EXPECT_EQ(stats.total_bytes, glb->size());

  auto scene = decode_glb(glb->data(), glb->size());
  ASSERT_TRUE(scene) << scene.error().message;
  ASSERT_EQ(scene->nodes.size(), 1u);
  EXPECT_EQ(scene->nodes[0].mesh.triangle_count(), triangles);
  const nlohmann::json extras = nlohmann::json::parse(scene->extras_json);
  EXPECT_EQ(extras["rgbdcast"]["source"], "frame-0.png");
  EXPECT_EQ(extras["rgbdcast"]["frame"], 0);
  EXPECT_EQ(extras["rgbdcast"]["reduction"], choices);
}

TEST(KeyframeGlb, CaptureMustBeAnObject) {
  TexturedFrame empty;
  auto glb = encode_keyframe_glb(empty, nlohmann::json::array({1, 2}), GlbWriteOptions{});
  ASSERT_FALSE(glb);
  EXPECT_EQ(glb.error().code, ErrorCode::kInvalidArgument);
}

}  // namespace
}  // namespace rgbdcast
