// rgbdcast reduce --sequence and eval-trajectory on real sequences.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "tests/common/gltf_validator.h"
#include "tests/common/run_command.h"
#include "tests/common/test_data.h"

namespace fs = std::filesystem;

namespace rgbdcast {
namespace {

TEST(SequenceCli, AugmentedIclBecomesOneValidMultiViewGlb) {
  REQUIRE_DATA("augmented_icl_livingroom");
  const std::string dir = test::temp_dir("seq-cli");
  const std::string input = test::data_path("augmented_icl_livingroom");
  auto r =
      test::run_command(test::rgbdcast_binary() + " reduce --preset paper --sequence --input " + input + " --out " +
                        dir + "/scene.glb --report " + dir + "/r.json --trajectory " + dir + "/est.log");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::ifstream in(dir + "/r.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  const auto& frames = j.at("frames");
  ASSERT_EQ(frames.size(), 5u);
  int keyframes = 0;
  for (const auto& f : frames) {
    for (const char* k : {"index", "timestamp", "matches", "inliers", "keyframe", "pose", "ms", "method", "track_ms"})
      EXPECT_TRUE(f.contains(k)) << k;
    keyframes += f.at("keyframe").get<bool>();
    ASSERT_EQ(f.at("pose").size(), 4u);  // row-major 4x4
  }
  EXPECT_GE(keyframes, 1);
  EXPECT_EQ(frames[0].at("pose")[0][0].get<double>(), 1.0);  // the first frame defines the world
  EXPECT_EQ(j.at("bytes").get<long>(), static_cast<long>(fs::file_size(dir + "/scene.glb")));
  EXPECT_GLTF_VALID(dir + "/scene.glb");

  // The estimated trajectory against the dataset's ground truth: consecutive frames within 1 cm and 0.5 degrees.
  auto e = test::run_command(test::rgbdcast_binary() + " eval-trajectory --estimated " + dir +
                             "/est.log --groundtruth " + input + "/trajectory.log");
  ASSERT_EQ(e.exit_code, 0) << e.err;
  const nlohmann::json rpe = nlohmann::json::parse(e.out);
  EXPECT_EQ(rpe.at("pairs").size(), 4u);
  EXPECT_LT(rpe.at("translation_max_m").get<double>(), 0.01);
  EXPECT_LT(rpe.at("rotation_max_deg").get<double>(), 0.5);
}

// With no --preset, sequence mode reduces every keyframe with the realtime preset, each under its own default budget
// (min(40 kB, a quarter of its JPEG90+PNG16 payload): 40 kB on augmented ICL, whose payload is about 182 kB).
TEST(SequenceCli, TheDefaultReducesEachKeyframeWithTheRealtimePreset) {
  REQUIRE_DATA("augmented_icl_livingroom");
  const std::string dir = test::temp_dir("seq-default");
  auto r = test::run_command(
      test::rgbdcast_binary() + " reduce --sequence --keyframe-gap 1 --to 2 --no-progress --input " +
      test::data_path("augmented_icl_livingroom") + " --out " + dir + "/scene.glb --report " + dir + "/r.json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::ifstream in(dir + "/r.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  const auto& keyframes = j.at("keyframes");
  ASSERT_EQ(keyframes.size(), 3u) << j;
  for (const auto& k : keyframes) {
    EXPECT_EQ(k.at("reduction").at("preset"), "realtime") << k;
    EXPECT_DOUBLE_EQ(k.at("reduction").at("budget").at("budget_bytes").get<double>(), 40000.0) << k;
    EXPECT_LE(k.at("reduction").at("budget").at("glb_bytes").get<double>(), 40000.0 * 1.1) << k;
    EXPECT_LE(k.at("triangles").get<long>(), 20000) << k;
  }
  EXPECT_GLTF_VALID(dir + "/scene.glb");
}

TEST(SequenceCli, DroppingCoveredTrianglesSavesBytes) {
  REQUIRE_DATA("augmented_icl_livingroom");
  const std::string dir = test::temp_dir("seq-covered");
  const std::string input = test::data_path("augmented_icl_livingroom");
  // Every frame a keyframe (--keyframe-gap 1) so that later keyframes overlap earlier ones; the first three frames
  // are enough for that, and each paper-preset keyframe costs seconds.
  const std::string base = test::rgbdcast_binary() + " reduce --preset paper --sequence --input " + input +
                           " --texture frame --keyframe-gap 1 --to 2 ";
  auto keep = test::run_command(base + "--keep-covered --out " + dir + "/keep.glb --report " + dir + "/keep.json");
  auto drop = test::run_command(base + "--out " + dir + "/drop.glb --report " + dir + "/drop.json");
  ASSERT_EQ(keep.exit_code, 0) << keep.err;
  ASSERT_EQ(drop.exit_code, 0) << drop.err;
  std::ifstream a(dir + "/keep.json"), b(dir + "/drop.json");
  const nlohmann::json jk = nlohmann::json::parse(a), jd = nlohmann::json::parse(b);
  if (jk.at("keyframes").size() < 2) GTEST_SKIP() << "one keyframe only: nothing to drop";
  EXPECT_LT(jd.at("triangles").get<long>(), jk.at("triangles").get<long>());
  EXPECT_LT(jd.at("bytes").get<long>(), jk.at("bytes").get<long>());
  EXPECT_GLTF_VALID(dir + "/drop.glb");
}

TEST(SequenceCli, WidelySpacedFramesAreSkippedWithAClearMessage) {
  REQUIRE_DATA("icl_nuim_livingroom");
  const std::string dir = test::temp_dir("seq-icl");
  auto r = test::run_command(test::rgbdcast_binary() + " reduce --preset paper --sequence --input " +
                             test::data_path("icl_nuim_livingroom") + " --out " + dir + "/scene.glb --report " + dir +
                             "/r.json");
  // The first frame is a keyframe on its own; the others (0.3-1 m apart, no timestamps: 33 ms apart at 30 Hz) fail
  // the 20x20 window, and whatever the wider tries find is faster than a hand-held camera: skipped, with a reason.
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::ifstream in(dir + "/r.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  int skipped = 0;
  for (const auto& f : j.at("frames"))
    if (!f.at("tracked").get<bool>()) {
      ++skipped;
      EXPECT_FALSE(f.at("message").get<std::string>().empty());
    }
  EXPECT_GE(skipped, 3);
  EXPECT_NE(r.out.find("skipped"), std::string::npos) << r.out;
}

TEST(SequenceCli, UnknownTrackingModeIsAClearError) {
  REQUIRE_DATA("augmented_icl_livingroom");
  const std::string dir = test::temp_dir("seq-tracking");
  auto r = test::run_command(test::rgbdcast_binary() + " reduce --preset paper --sequence --tracking fast --input " +
                             test::data_path("augmented_icl_livingroom") + " --out " + dir + "/scene.glb");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--tracking must be robust, paper or live"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir + "/scene.glb"));
}

TEST(SequenceCli, MissingGroundTruthIsAClearError) {
  const std::string dir = test::temp_dir("seq-gt");
  std::ofstream(dir + "/est.txt") << "1.0 0 0 0 0 0 0 1\n2.0 0 0 0.1 0 0 0 1\n";
  auto r = test::run_command(test::rgbdcast_binary() + " eval-trajectory --estimated " + dir +
                             "/est.txt --groundtruth " + dir + "/missing.txt");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("not found"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace rgbdcast

namespace rgbdcast {
namespace {

// Novel views: the mesh reduced from frame 0, seen from where frames 1..4 really were, against their real images.
TEST(NovelViewCli, FrameZeroMeshPredictsTheLaterFrames) {
  REQUIRE_DATA("augmented_icl_livingroom");
  const std::string dir = test::temp_dir("novel");
  const std::string input = test::data_path("augmented_icl_livingroom");
  auto r = test::run_command(test::rgbdcast_binary() + " reduce --preset paper --input " + input + " --frame 0 --out " +
                             dir + "/f0.glb");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto eval = [&](int k, bool true_pose) {
    auto e = test::run_command(test::rgbdcast_binary() + " eval --input " + input + " --frame " + std::to_string(k) +
                               " --scene " + dir + "/f0.glb" +
                               (true_pose ? " --groundtruth " + input + "/trajectory.log --scene-frame 0" : ""));
    EXPECT_EQ(e.exit_code, 0) << e.err;
    return e.exit_code == 0 ? nlohmann::json::parse(e.out) : nlohmann::json::object();
  };
  for (int k = 1; k <= 4; k += 3) {
    const nlohmann::json at_truth = eval(k, true), stale = eval(k, false);
    ASSERT_TRUE(at_truth.contains("psnr_db") && stale.contains("psnr_db"));
    EXPECT_GT(at_truth["coverage"].get<double>(), 0.6) << "frame " << k;
    EXPECT_GT(at_truth["psnr_db"].get<double>(), 28.0) << "frame " << k;
    // Seen from where frame k really was, the mesh predicts frame k far better than from where frame 0 was: the
    // camera moved ~2.4 cm and 0.75 degrees a frame, and a wrong (inverted, mirrored) pose would not gain.
    EXPECT_GT(at_truth["psnr_db"].get<double>(), stale["psnr_db"].get<double>() + 5.0) << "frame " << k;
    EXPECT_GT(at_truth["ssim"].get<double>(), stale["ssim"].get<double>()) << "frame " << k;
  }
  auto bad = test::run_command(test::rgbdcast_binary() + " eval --input " + input + " --frame 1 --scene " + dir +
                               "/f0.glb --groundtruth " + input + "/trajectory.log");
  EXPECT_EQ(bad.exit_code, 2) << "--groundtruth without --scene-frame";
}

}  // namespace
}  // namespace rgbdcast
