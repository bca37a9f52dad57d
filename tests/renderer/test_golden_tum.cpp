// Golden images of a real scene: TUM fr1/xyz frame 0 reduced with the paper's parameters and textured with the
// undistorted atlas, rendered by both backends in both modes from the capture camera and from a look-at camera.
// The reduction is deterministic, so these change only when the reduction, the atlas or a renderer does: review the
// actual image, then promote it (scripts/promote_goldens.sh).
#include "atlas/atlas.h"
#include "input/frame_source.h"
#include "reduction/pipeline.h"
#include "tests/common/test_data.h"
#include "tests/renderer/image_compare.h"
#include "tests/renderer/renderer_fixture.h"

namespace rgbdcast::test {
namespace {

// Reduced once for all backends and views.
const Scene* tum_scene(std::string* error) {
  static Scene scene;
  static std::string failure;
  static bool done = false;
  if (!done) {
    done = true;
    SourceOptions o;
    o.intrinsics = "fr1";
    auto src = open_frame_source(data_path("tum/rgbd_dataset_freiburg1_xyz"), o);
    auto frame = src ? (*src)->frame(0) : Result<RgbdFrame>(src.error());
    auto reduced = frame ? reduce_frame(*frame, ReductionParams{}) : Result<ReducedFrame>(frame.error());
    AtlasOptions atlas;
    atlas.mode = TextureMode::kAtlas;
    auto textured = reduced ? build_atlas(reduced->mesh, frame->color_rgb, frame->intrinsics, atlas)
                            : Result<AtlasResult>(reduced.error());
    if (!textured) {
      failure = textured.error().message;
    } else {
      SceneNode node;
      node.mesh = std::move(textured->mesh);
      scene.nodes.push_back(std::move(node));
      CaptureCamera cam;
      cam.intrinsics = frame->intrinsics;
      scene.cameras.push_back(cam);
    }
  }
  *error = failure;
  return failure.empty() ? &scene : nullptr;
}

class TumGolden : public BackendTest {
 protected:
  void check(RenderMode mode, bool capture) {
    REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz");
    std::string error;
    const Scene* scene = tum_scene(&error);
    ASSERT_NE(scene, nullptr) << error;
    auto id = renderer_->upload(*scene);
    ASSERT_TRUE(id) << id.error().message;
    const ViewCamera cam = tum_golden_camera(scene->cameras[0], capture);
    expect_matches_golden(*renderer_, id.value(), cam, mode, 2.0f, 0.25,
                          "tum_" + GetParam() + "_" + to_string(mode) + (capture ? "_capture" : "_lookat"));
  }
};

TEST_P(TumGolden, MeshCaptureCamera) { check(RenderMode::kMesh, true); }
TEST_P(TumGolden, MeshLookAtCamera) { check(RenderMode::kMesh, false); }
TEST_P(TumGolden, PointsCaptureCamera) { check(RenderMode::kPoints, true); }
TEST_P(TumGolden, PointsLookAtCamera) { check(RenderMode::kPoints, false); }

INSTANTIATE_TEST_SUITE_P(Backends, TumGolden, kBackends);

}  // namespace
}  // namespace rgbdcast::test
