// Golden images of the synthetic scene: both backends x both modes x both cameras, compared with PNGs in
// tests/renderer/golden/ (5/255 per channel, at most 0.1 % of pixels, one-pixel shift allowed).
#include "tests/renderer/image_compare.h"
#include "tests/renderer/renderer_fixture.h"
#include "tests/renderer/synthetic_scene.h"

namespace rgbdcast::test {
namespace {

class Golden : public BackendTest {
 protected:
  void check(RenderMode mode, const ViewCamera& cam, const std::string& camera_name) {
    auto id = renderer_->upload(synthetic_scene());
    ASSERT_TRUE(id) << id.error().message;
    RenderOptions opt;
    opt.mode = mode;
    opt.point_size_px = 3.0f;
    opt.background = {16, 16, 24};
    auto r = renderer_->render(id.value(), cam, opt);
    ASSERT_TRUE(r) << r.error().message;
    // Something of every node is on screen: a sanity floor on coverage so a blank golden can never pass.
    long drawn = 0;
    for (int y = 0; y < r->color.height; ++y)
      for (int x = 0; x < r->color.width; ++x) drawn += r->color.pixel(x, y)[3] == 255;
    const double coverage = static_cast<double>(drawn) / (r->color.width * r->color.height);
    EXPECT_GT(coverage, mode == RenderMode::kMesh ? 0.10 : 0.03) << "drawn fraction " << coverage;
    const std::string name = GetParam() + "_" + to_string(mode) + "_" + camera_name;
    const std::string failure = check_golden(name, r->color);
    EXPECT_TRUE(failure.empty()) << failure;
  }
};

TEST_P(Golden, MeshIntrinsicsCamera) { check(RenderMode::kMesh, intrinsics_camera(), "intrinsics"); }
TEST_P(Golden, MeshLookAtCamera) { check(RenderMode::kMesh, look_at_camera(), "lookat"); }
TEST_P(Golden, PointsIntrinsicsCamera) { check(RenderMode::kPoints, intrinsics_camera(), "intrinsics"); }
TEST_P(Golden, PointsLookAtCamera) { check(RenderMode::kPoints, look_at_camera(), "lookat"); }

// The texture is sampled the right way up: the quad's top-left texel block (pure red in the texture) shows at the
// quad's top-left vertex, which projects to a known pixel.
TEST_P(Golden, TextureOrientation) {
  const Scene scene = synthetic_scene();
  auto id = renderer_->upload(scene);
  ASSERT_TRUE(id);
  const ViewCamera cam = intrinsics_camera();
  auto r = renderer_->render(id.value(), cam, RenderOptions{});
  ASSERT_TRUE(r);
  const Eigen::Vector3f p = scene.nodes[0].mesh.positions[0];  // uv (0, 0)
  const int u = static_cast<int>(std::lround(cam.fx * p.x() / p.z() + cam.cx)) + 2;
  const int v = static_cast<int>(std::lround(cam.fy * p.y() / p.z() + cam.cy)) + 2;
  const std::uint8_t* px = r->color.pixel(u, v);
  EXPECT_GT(px[0], 200);
  EXPECT_LT(px[1], 60);
  EXPECT_LT(px[2], 60);
}

INSTANTIATE_TEST_SUITE_P(Backends, Golden, kBackends);

}  // namespace
}  // namespace rgbdcast::test
