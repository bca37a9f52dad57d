// Golden images of the realtime preset (the default of `rgbdcast reduce` and the service) on a real frame: TUM
// fr1/xyz frame 0 reduced as `rgbdcast reduce` does with no options (realtime, its default byte budget, frame
// texture, Draco geometry), encoded to a GLB and decoded again, so the goldens show what a user receives. Rendered
// by both backends (mesh mode) from the capture camera and from a look-at camera, with the tolerance of the other
// goldens (5/255 per channel, a one-pixel shift, at most 0.1 % of the pixels off).
//
// The realtime mesh changes whenever its reduction does (reduction/depth_mesh.cpp, reduction/simplify.cpp,
// pipeline/frame_scene.cpp). Then, after looking at the new images, regenerate these goldens with one command:
//   scripts/regenerate_realtime_goldens.sh
// (it builds this test, runs it, promotes its realtime_* actual images and runs it again).
#include <filesystem>
#include <iostream>

#include "gltf/gltf_io.h"
#include "input/frame_source.h"
#include "pipeline/frame_defaults.h"
#include "pipeline/frame_scene.h"
#include "pipeline/keyframe_glb.h"
#include "tests/common/test_data.h"
#include "tests/renderer/image_compare.h"
#include "tests/renderer/renderer_fixture.h"

namespace rgbdcast::test {
namespace {

const char* kTum = "tum/rgbd_dataset_freiburg1_xyz";

// Reduced, encoded and decoded once for all backends and views.
const Scene* realtime_scene(std::string* error) {
  static Scene scene;
  static std::string failure;
  static bool done = false;
  if (!done) {
    done = true;
    auto made = [&]() -> Result<Scene> {
      SourceOptions so;
      so.intrinsics = "fr1";
      auto src = open_frame_source(data_path(kTum), so);
      if (!src) return src.error();
      auto frame = (*src)->frame(0);
      if (!frame) return frame.error();
      // The capture camera's source paths go into the GLB, and so into the bytes a budget fits: relative to the data
      // folder, so that the scene does not depend on where the checkout is (an absolute path 5 characters longer
      // took one JPEG quality step off this frame's texture).
      const std::filesystem::path data = data_path("");
      frame->color_path = std::filesystem::path(frame->color_path).lexically_relative(data).string();
      frame->depth_path = std::filesystem::path(frame->depth_path).lexically_relative(data).string();
      FrameReductionOptions o;  // what `rgbdcast reduce` (app/reduce_common.cpp) gives with no options
      o.params = reduction_preset(kDefaultPreset);
      o.glb.geometry_codec = default_geometry_codec(kDefaultPreset);
      auto budget = default_budget_kb(*frame);
      if (!budget) return budget.error();
      o.budget_kb = *budget;
      auto textured = reduce_and_texture(*frame, o);
      if (!textured) return textured.error();
      std::cout << "realtime golden scene: " << reduction_choices(*textured).dump()
                << "\n";  // what a mismatch came from
      auto glb = encode_glb(frame_scene(std::move(*textured), "{}"), o.glb);
      if (!glb) return glb.error();
      return decode_glb(glb->data(), glb->size());
    }();
    if (made)
      scene = std::move(*made);
    else
      failure = made.error().message;
  }
  *error = failure;
  return failure.empty() ? &scene : nullptr;
}

class RealtimeGolden : public BackendTest {
 protected:
  void check(bool capture) {
    REQUIRE_DATA(kTum);
    std::string error;
    const Scene* scene = realtime_scene(&error);
    ASSERT_NE(scene, nullptr) << error;
    ASSERT_FALSE(scene->cameras.empty());
    // The default preset's mesh: at most the 20k triangles.
    EXPECT_LE(scene->triangle_count(), 20000u);
    auto id = renderer_->upload(*scene);
    ASSERT_TRUE(id) << id.error().message;
    const ViewCamera cam = tum_golden_camera(scene->cameras[0], capture);
    // At the capture pose the mesh covers nearly every valid pixel (about 75 % of this frame has depth).
    expect_matches_golden(*renderer_, id.value(), cam, RenderMode::kMesh, 2.0f, capture ? 0.6 : 0.25,
                          "realtime_tum_" + GetParam() + (capture ? "_capture" : "_lookat"));
  }
};

TEST_P(RealtimeGolden, MeshCaptureCamera) { check(true); }
TEST_P(RealtimeGolden, MeshLookAtCamera) { check(false); }

INSTANTIATE_TEST_SUITE_P(Backends, RealtimeGolden, kBackends);

}  // namespace
}  // namespace rgbdcast::test
