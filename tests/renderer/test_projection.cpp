// The projection contract of renderer/render_camera.h: a point projecting to (u, v) lands in the pixel centred at
// (u, v), in both backends, with depth read back as metres along z.
#include <Eigen/Geometry>
#include <cmath>

#include "renderer/render_camera.h"
#include "tests/renderer/renderer_fixture.h"

namespace rgbdcast::test {
namespace {

constexpr int kW = 200, kH = 150;

ViewCamera small_camera() {
  ViewCamera c;
  c.fx = 180.0;
  c.fy = 170.0;
  c.cx = 97.5;
  c.cy = 71.25;
  c.width = kW;
  c.height = kH;
  return c;
}

// The camera-frame point at depth z that projects to pixel coordinates (u, v).
Eigen::Vector3f at_pixel(const ViewCamera& c, double u, double v, double z) {
  return Eigen::Vector3d((u - c.cx) / c.fx * z, (v - c.cy) / c.fy * z, z).cast<float>();
}

struct Lit {
  int count = 0, x = -1, y = -1;
};
Lit lit_pixels(const Image& im) {
  Lit l;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x)
      if (im.pixel(x, y)[3] != 0) {
        ++l.count;
        l.x = x;
        l.y = y;
      }
  return l;
}

class Projection : public BackendTest {};

TEST_P(Projection, SinglePointLandsOnItsPixel) {
  const ViewCamera cam = small_camera();
  // Integer pixel centres, and off-centre positions within the pixel (up to 0.4 px away), at several depths.
  const double cases[][3] = {{10, 20, 0.7},     {123, 45, 2.0},      {0, 0, 1.0},       {199, 149, 3.5},
                             {57.4, 88.6, 1.3}, {150.35, 12.6, 4.0}, {97.2, 71.25, 1.0}};
  for (const auto& c : cases) {
    Scene scene;
    SceneNode node;
    node.points.positions.push_back(at_pixel(cam, c[0], c[1], c[2]));
    node.points.colors.push_back(Rgb8{200, 100, 50});
    scene.nodes.push_back(node);
    auto id = renderer_->upload(scene);
    ASSERT_TRUE(id) << id.error().message;
    RenderOptions opt;
    opt.mode = RenderMode::kPoints;
    opt.want_depth = true;
    opt.background = {0, 0, 255};
    auto r = renderer_->render(id.value(), cam, opt);
    ASSERT_TRUE(r) << r.error().message;
    const Lit l = lit_pixels(r->color);
    const int ex = static_cast<int>(std::lround(c[0])), ey = static_cast<int>(std::lround(c[1]));
    ASSERT_EQ(l.count, 1) << "point at (" << c[0] << "," << c[1] << ")";
    EXPECT_EQ(l.x, ex) << "u = " << c[0];
    EXPECT_EQ(l.y, ey) << "v = " << c[1];
    const std::uint8_t* p = r->color.pixel(ex, ey);
    EXPECT_EQ(p[0], 200);
    EXPECT_EQ(p[1], 100);
    EXPECT_EQ(p[2], 50);
    EXPECT_EQ(p[3], 255);
    const std::uint8_t* bg = r->color.pixel(ex == 0 ? 1 : 0, 0);
    EXPECT_EQ(bg[2], 255) << "background colour";
    EXPECT_EQ(bg[3], 0) << "background alpha";
    EXPECT_NEAR(r->depth_m[static_cast<size_t>(ey) * kW + ex], c[2], 1e-4 * c[2]);
    EXPECT_EQ(r->depth_m[0 == ex && 0 == ey ? 1 : 0], 0.0f) << "background depth";
    renderer_->release(id.value());
  }
}

TEST_P(Projection, TinyTriangleCoversExactlyOnePixelThroughPoses) {
  // A camera away from the origin and a node with its own transform: the composition camera <- world <- node must
  // still put the triangle on pixel (120, 40).
  ViewCamera cam = small_camera();
  const Eigen::Affine3d cam_pose =
      Eigen::Translation3d(0.3, -0.2, 0.5) * Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.2, 1.0, 0.1).normalized());
  cam.camera_to_world = cam_pose.matrix();
  const Eigen::Affine3d node_pose =
      Eigen::Translation3d(-1.0, 0.5, 2.0) * Eigen::AngleAxisd(-0.7, Eigen::Vector3d::UnitX());
  const double z = 1.7;
  Scene scene;
  SceneNode node;
  node.to_world = node_pose.matrix();
  const Eigen::Matrix4d node_from_cam = node_pose.inverse().matrix() * cam_pose.matrix();
  for (auto uv : {Eigen::Vector2d(119.6, 39.6), Eigen::Vector2d(120.6, 39.7), Eigen::Vector2d(119.7, 40.6)}) {
    const Eigen::Vector3d pc = at_pixel(cam, uv.x(), uv.y(), z).cast<double>();
    node.mesh.positions.push_back((node_from_cam * pc.homogeneous()).head<3>().cast<float>());
    node.mesh.colors.push_back(Rgb8{10, 250, 90});
  }
  node.mesh.indices = {0, 1, 2};
  scene.nodes.push_back(node);
  auto id = renderer_->upload(scene);
  ASSERT_TRUE(id) << id.error().message;
  RenderOptions opt;
  opt.want_depth = true;
  auto r = renderer_->render(id.value(), cam, opt);
  ASSERT_TRUE(r) << r.error().message;
  const Lit l = lit_pixels(r->color);
  ASSERT_EQ(l.count, 1);
  EXPECT_EQ(l.x, 120);
  EXPECT_EQ(l.y, 40);
  EXPECT_EQ(r->color.pixel(120, 40)[1], 250);
  EXPECT_NEAR(r->depth_m[40 * kW + 120], z, 1e-4);
}

TEST_P(Projection, SplatIsASquareOfPointSize) {
  const ViewCamera cam = small_camera();
  Scene scene;
  SceneNode node;
  node.points.positions.push_back(at_pixel(cam, 60.0, 30.0, 1.0));
  node.points.colors.push_back(Rgb8{255, 255, 255});
  scene.nodes.push_back(node);
  auto id = renderer_->upload(scene);
  ASSERT_TRUE(id);
  RenderOptions opt;
  opt.mode = RenderMode::kPoints;
  opt.point_size_px = 5.0f;
  auto r = renderer_->render(id.value(), cam, opt);
  ASSERT_TRUE(r);
  int count = 0, minx = kW, maxx = -1, miny = kH, maxy = -1;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x)
      if (r->color.pixel(x, y)[3]) {
        ++count;
        minx = std::min(minx, x);
        maxx = std::max(maxx, x);
        miny = std::min(miny, y);
        maxy = std::max(maxy, y);
      }
  EXPECT_EQ(count, 25);
  EXPECT_EQ(minx, 58);
  EXPECT_EQ(maxx, 62);
  EXPECT_EQ(miny, 28);
  EXPECT_EQ(maxy, 32);
}

INSTANTIATE_TEST_SUITE_P(Backends, Projection, kBackends);

}  // namespace
}  // namespace rgbdcast::test

namespace rgbdcast::test {
namespace {

// ViewCamera::look_at (scene/camera.cpp) must give an upright, unmirrored camera: looking along +z with up = -y is
// the identity rotation, and a point up and to the right of the target shows up and to the right in the image.
TEST(LookAt, UprightAndUnmirrored) {
  auto cam = ViewCamera::look_at({0, 0, 0}, {0, 0, 2}, {0, -1, 0}, 60.0, 320, 240);
  ASSERT_TRUE(cam);
  const Eigen::Matrix3d r0 = cam->camera_to_world.block<3, 3>(0, 0);
  EXPECT_TRUE(r0.isApprox(Eigen::Matrix3d::Identity(), 1e-12)) << cam->camera_to_world;
  auto side = ViewCamera::look_at({2, -1, 1}, {0, 0, 1}, {0, -1, 0}, 60.0, 320, 240);  // from the right, above
  ASSERT_TRUE(side);
  const Eigen::Matrix4d w2c = side->world_to_camera();
  // Seen from +x looking towards -x with y down, world +z is on the camera's right and world -y is up.
  const Eigen::Vector3d above = (w2c * Eigen::Vector4d(0, -0.5, 1, 1)).head<3>();
  EXPECT_LT(above.y(), 0.0) << "a point above the target must be in the upper half of the image";
  const Eigen::Vector3d right = (w2c * Eigen::Vector4d(0, 0, 1.5, 1)).head<3>();
  EXPECT_GT(right.x(), 0.0) << "world +z must be on the right of this camera";
  const Eigen::Matrix3d r = side->camera_to_world.block<3, 3>(0, 0);
  EXPECT_NEAR(r.determinant(), 1.0, 1e-9);
}

}  // namespace
}  // namespace rgbdcast::test
