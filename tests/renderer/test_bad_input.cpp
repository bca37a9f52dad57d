// Bad input gives a clear error, never a crash: sizes, NaN poses, empty scenes, unknown ids, broken meshes, and the
// decided behaviour for a textured mesh without its texture (vertex colours, or an error when it has none).
#include <cmath>
#include <limits>

#include "tests/renderer/renderer_fixture.h"
#include "tests/renderer/synthetic_scene.h"

namespace rgbdcast::test {
namespace {

class BadInput : public BackendTest {
 protected:
  ResidentSceneId upload_synthetic() {
    auto id = renderer_->upload(synthetic_scene());
    EXPECT_TRUE(id) << id.error().message;
    return id ? id.value() : 0;
  }
};

TEST_P(BadInput, ImageSizeOutOfRange) {
  const ResidentSceneId id = upload_synthetic();
  for (auto [w, h] : {std::pair{0, 240}, std::pair{320, 0}, std::pair{-5, 10}, std::pair{kMaxImageSize + 1, 100},
                      std::pair{100, 100000}}) {
    ViewCamera cam = intrinsics_camera();
    cam.width = w;
    cam.height = h;
    auto r = renderer_->render(id, cam, RenderOptions{});
    ASSERT_FALSE(r) << w << "x" << h;
    EXPECT_EQ(r.error().code, ErrorCode::kInvalidArgument);
    EXPECT_NE(r.error().message.find("image size"), std::string::npos) << r.error().message;
  }
  // The renderer still works afterwards.
  EXPECT_TRUE(renderer_->render(id, intrinsics_camera(), RenderOptions{}));
}

TEST_P(BadInput, NanOrInfInCamera) {
  const ResidentSceneId id = upload_synthetic();
  ViewCamera cam = intrinsics_camera();
  cam.camera_to_world(0, 3) = std::numeric_limits<double>::quiet_NaN();
  auto r = renderer_->render(id, cam, RenderOptions{});
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(r.error().message.find("NaN"), std::string::npos) << r.error().message;
  cam = intrinsics_camera();
  cam.fx = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(renderer_->render(id, cam, RenderOptions{}));
  cam = intrinsics_camera();
  cam.camera_to_world(0, 0) = 3.0;  // not a rotation
  EXPECT_FALSE(renderer_->render(id, cam, RenderOptions{}));
  RenderOptions opt;
  opt.point_size_px = std::nanf("");
  EXPECT_FALSE(renderer_->render(id, intrinsics_camera(), opt));
  opt.point_size_px = 0.0f;
  EXPECT_FALSE(renderer_->render(id, intrinsics_camera(), opt));
}

TEST_P(BadInput, EmptyScene) {
  Scene empty;
  auto a = renderer_->upload(empty);
  ASSERT_FALSE(a);
  EXPECT_EQ(a.error().code, ErrorCode::kEmpty);
  Scene nodes_without_geometry;
  nodes_without_geometry.nodes.resize(3);
  auto b = renderer_->upload(nodes_without_geometry);
  ASSERT_FALSE(b);
  EXPECT_EQ(b.error().code, ErrorCode::kEmpty);
  EXPECT_NE(b.error().message.find("empty"), std::string::npos);
}

TEST_P(BadInput, UnknownOrReleasedId) {
  auto r = renderer_->render(12345, intrinsics_camera(), RenderOptions{});
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, ErrorCode::kNotFound);
  const ResidentSceneId id = upload_synthetic();
  renderer_->release(id);
  renderer_->release(id);  // twice is harmless
  EXPECT_FALSE(renderer_->render(id, intrinsics_camera(), RenderOptions{}));
}

TEST_P(BadInput, MalformedMesh) {
  Scene s = synthetic_scene();
  s.nodes[1].mesh.indices.push_back(9999);
  s.nodes[1].mesh.indices.push_back(0);
  s.nodes[1].mesh.indices.push_back(1);
  auto a = renderer_->upload(s);
  ASSERT_FALSE(a);
  EXPECT_EQ(a.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(a.error().message.find("out of range"), std::string::npos) << a.error().message;
  s = synthetic_scene();
  s.nodes[1].mesh.colors.pop_back();
  EXPECT_FALSE(renderer_->upload(s));
  s = synthetic_scene();
  s.nodes[2].to_world(1, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(renderer_->upload(s));
  s = synthetic_scene();
  s.nodes[0].mesh.texture.data.resize(10);  // size does not match width*height
  EXPECT_FALSE(renderer_->upload(s));
  s = synthetic_scene();
  s.nodes[0].mesh.texture = Image{};
  s.nodes[0].mesh.texture_encoded = {1, 2, 3, 4};  // not a JPEG/PNG
  s.nodes[0].mesh.texture_mime = "image/jpeg";
  auto c = renderer_->upload(s);
  ASSERT_FALSE(c);
  EXPECT_NE(c.error().message.find("decode"), std::string::npos) << c.error().message;
}

// Decision: a mesh with uvs but no texture draws its vertex colours; with no colours either it is an error.
TEST_P(BadInput, TexturedMeshWithoutTexture) {
  Scene s = synthetic_scene();
  s.nodes[0].mesh.texture = Image{};
  auto a = renderer_->upload(s);
  ASSERT_FALSE(a);
  EXPECT_EQ(a.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(a.error().message.find("no texture and no vertex colours"), std::string::npos) << a.error().message;
  EXPECT_NE(a.error().message.find("textured_quad"), std::string::npos) << a.error().message;

  s.nodes[0].mesh.colors.assign(s.nodes[0].mesh.positions.size(), Rgb8{0, 255, 255});
  auto b = renderer_->upload(s);
  ASSERT_TRUE(b) << b.error().message;
  const ViewCamera cam = intrinsics_camera();
  auto r = renderer_->render(b.value(), cam, RenderOptions{});
  ASSERT_TRUE(r);
  // The quad's centre shows the vertex colour (cyan), not the texture.
  const Eigen::Vector3f p = s.nodes[0].mesh.positions[6 * 17 + 3];
  const int u = static_cast<int>(std::lround(cam.fx * p.x() / p.z() + cam.cx));
  const int v = static_cast<int>(std::lround(cam.fy * p.y() / p.z() + cam.cy));
  const std::uint8_t* px = r->color.pixel(u, v);
  EXPECT_EQ(px[0], 0);
  EXPECT_EQ(px[1], 255);
  EXPECT_EQ(px[2], 255);
}

// A texture that arrives encoded only (as from a GLB) is decoded by the renderer.
TEST_P(BadInput, EncodedTextureIsDecoded) {
  Scene s;
  SceneNode n;
  n.mesh.positions = {{-0.5f, -0.5f, 1.0f}, {0.5f, -0.5f, 1.0f}, {0.0f, 0.5f, 1.0f}};
  n.mesh.uvs = {{0.5f, 0.5f}, {0.5f, 0.5f}, {0.5f, 0.5f}};
  n.mesh.indices = {0, 1, 2};
  // A 1x1 PNG, pixel (10, 200, 30).
  n.mesh.texture_encoded = {0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48,
                            0x44, 0x52, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x01, 0x08, 0x02, 0x00, 0x00,
                            0x00, 0x90, 0x77, 0x53, 0xde, 0x00, 0x00, 0x00, 0x0c, 0x49, 0x44, 0x41, 0x54, 0x78,
                            0x9c, 0x63, 0xe0, 0x3a, 0x21, 0x07, 0x00, 0x01, 0xd0, 0x00, 0xf1, 0x24, 0x5c, 0x91,
                            0xf4, 0x00, 0x00, 0x00, 0x00, 0x49, 0x45, 0x4e, 0x44, 0xae, 0x42, 0x60, 0x82};
  n.mesh.texture_mime = "image/png";
  s.nodes.push_back(n);
  auto id = renderer_->upload(s);
  ASSERT_TRUE(id) << id.error().message;
  ViewCamera cam = intrinsics_camera();
  auto r = renderer_->render(id.value(), cam, RenderOptions{});
  ASSERT_TRUE(r);
  const std::uint8_t* px = r->color.pixel(160, 120);
  EXPECT_EQ(px[0], 10);
  EXPECT_EQ(px[1], 200);
  EXPECT_EQ(px[2], 30);
}

INSTANTIATE_TEST_SUITE_P(Backends, BadInput, kBackends);

}  // namespace
}  // namespace rgbdcast::test
