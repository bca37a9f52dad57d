// rgbdcast eval at novel views, as a user runs it, on a real sequence with ground truth (TUM fr1/xyz frames 200-319).
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "gltf/gltf_io.h"
#include "input/frame_source.h"
#include "reduction/pipeline.h"
#include "tests/common/run_command.h"
#include "tests/common/test_data.h"

namespace rgbdcast {
namespace {

const char* kSeq = "tum/rgbd_dataset_freiburg1_xyz_200_319";

nlohmann::json run_eval(const std::string& args) {
  const std::string input = test::data_path(kSeq);
  auto r = test::run_command(test::rgbdcast_binary() + " eval --input " + input + " --groundtruth " + input +
                             "/groundtruth.txt --mode points --point-size 2 " + args);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return r.exit_code == 0 ? nlohmann::json::parse(r.out) : nlohmann::json::object();
}

// `eval --full-cloud --scene-frame I --frame N` must draw frame I's cloud from frame N's true pose. The broken
// command drew frame N's own cloud at the relative pose I->N; we measure that too, in the same run, by handing the
// same command frame N's cloud as a scene (a GLB whose world is frame N's camera frame), and require the fix to be
// far better than it.
TEST(EvalCli, FullCloudAtANovelViewIsTheSceneFramesCloud) {
  REQUIRE_DATA(kSeq);
  const std::string dir = test::temp_dir("eval-novel");
  auto source = open_frame_source(test::data_path(kSeq), SourceOptions{});
  ASSERT_TRUE(source) << source.error().message;
  for (int n : {10, 30}) {
    auto frame_n = (*source)->frame(static_cast<size_t>(n));
    ASSERT_TRUE(frame_n) << frame_n.error().message;
    Scene wrong;
    wrong.nodes.emplace_back();
    wrong.nodes[0].points = full_cloud(*frame_n);
    CaptureCamera cam;
    cam.intrinsics = frame_n->intrinsics;
    wrong.cameras.push_back(cam);
    GlbWriteOptions exact;
    exact.quantize = false;
    exact.meshopt = false;
    const std::string wrong_glb = dir + "/cloud_of_frame_" + std::to_string(n) + ".glb";
    ASSERT_TRUE(write_glb_file(wrong, wrong_glb, exact));

    const std::string frames = " --scene-frame 0 --frame " + std::to_string(n);
    const nlohmann::json fixed = run_eval("--full-cloud" + frames);
    const nlohmann::json broken = run_eval("--scene " + wrong_glb + frames);
    ASSERT_TRUE(fixed.contains("psnr_db") && broken.contains("psnr_db"));
    const double good = fixed["psnr_db"].get<double>(), bad = broken["psnr_db"].get<double>();
    std::printf(
        "frame 0's cloud seen from frame %d's true pose: %.2f dB (coverage %.3f); frame %d's own cloud at the "
        "relative pose (the old bug): %.2f dB\n",
        n, good, fixed["coverage"].get<double>(), n, bad);
    EXPECT_EQ(fixed["scene_frame"].get<int>(), 0);
    EXPECT_EQ(fixed["frame"].get<int>(), n);
    EXPECT_GT(good, bad + 6.0) << "frame " << n;
    EXPECT_GT(good, 18.0) << "frame " << n;  // a real prediction of frame n, not a misregistered copy of it
    // 4.5 cm / 4.2 deg away, frame 0 saw most of what frame 10 sees (31 cm / 12 deg away at frame 30, far less).
    if (n == 10) {
      EXPECT_GT(fixed["coverage"].get<double>(), 0.7);
    }
  }
  test::remove_tree_quietly(dir);
}

}  // namespace
}  // namespace rgbdcast
