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
    expect_matches_golden(*renderer_, id.value(), cam, mode, 3.0f, mode == RenderMode::kMesh ? 0.10 : 0.03,
                          GetParam() + "_" + to_string(mode) + "_" + camera_name);
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

namespace rgbdcast::test {
namespace {

// Upload once, render many: views at other sizes in between do not disturb a resident scene, the same view gives
// the same bytes again, and two resident scenes do not mix.
class Resident : public BackendTest {};

TEST_P(Resident, UploadOnceRenderMany) {
  double upload_ms = -1.0;
  auto id = renderer_->upload(synthetic_scene(), &upload_ms);
  ASSERT_TRUE(id) << id.error().message;
  EXPECT_GE(upload_ms, 0.0);
  Scene single;
  single.nodes.push_back(synthetic_scene().nodes[2]);  // only the point cloud
  auto id2 = renderer_->upload(single);
  ASSERT_TRUE(id2);
  EXPECT_NE(id.value(), id2.value());
  RenderOptions opt;
  opt.want_depth = true;
  auto first = renderer_->render(id.value(), intrinsics_camera(), opt);
  ASSERT_TRUE(first);
  EXPECT_GE(first->timings.render_ms, 0.0);
  EXPECT_GE(first->timings.readback_ms, 0.0);
  ViewCamera wide = ViewCamera::from_capture(synthetic_scene().cameras[0], kMaxImageSize, 16);
  auto edge = renderer_->render(id.value(), wide, opt);  // the largest width accepted
  ASSERT_TRUE(edge) << edge.error().message;
  EXPECT_EQ(edge->color.width, kMaxImageSize);
  auto other = renderer_->render(id2.value(), look_at_camera(), opt);
  ASSERT_TRUE(other);
  auto again = renderer_->render(id.value(), intrinsics_camera(), opt);
  ASSERT_TRUE(again);
  EXPECT_EQ(first->color.data, again->color.data);
  EXPECT_EQ(first->depth_m, again->depth_m);
  long differ = 0;
  for (size_t i = 0; i < first->color.data.size(); ++i) differ += first->color.data[i] != other->color.data[i];
  EXPECT_GT(differ, 1000) << "the second scene from another camera is another image";
}

INSTANTIATE_TEST_SUITE_P(Backends, Resident, kBackends);

}  // namespace
}  // namespace rgbdcast::test
