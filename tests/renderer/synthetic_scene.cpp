#include "tests/renderer/synthetic_scene.h"

#include <Eigen/Geometry>
#include <cmath>

namespace rgbdcast::test {

namespace {

// 64x48 RGB: 8-pixel checker cells tinted by a gradient, so both bilinear filtering and orientation show.
Image checker_texture() {
  Image t = Image::make(64, 48, 3);
  for (int y = 0; y < t.height; ++y)
    for (int x = 0; x < t.width; ++x) {
      const bool on = ((x / 8) + (y / 8)) % 2 == 0;
      std::uint8_t* p = t.pixel(x, y);
      p[0] = static_cast<std::uint8_t>(on ? 40 + 3 * x : 20);
      p[1] = static_cast<std::uint8_t>(on ? 60 + 4 * y : 30);
      p[2] = static_cast<std::uint8_t>(on ? 200 : 90 + y);
    }
  // A red top-left texel block: uv (0,0) is the top-left corner of the image.
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x) {
      std::uint8_t* p = t.pixel(x, y);
      p[0] = 255;
      p[1] = p[2] = 0;
    }
  return t;
}

}  // namespace

Scene synthetic_scene() {
  Scene scene;
  {
    SceneNode quad;
    quad.name = "textured_quad";
    const int nx = 16, ny = 12;
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i) {
        const float s = static_cast<float>(i) / nx, t = static_cast<float>(j) / ny;
        quad.mesh.positions.emplace_back(-0.7f + 0.8f * s, -0.5f + 0.6f * t, 2.0f + 0.3f * s);
        quad.mesh.uvs.emplace_back(s, t);
      }
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        const std::uint32_t a = j * (nx + 1) + i, b = a + 1, c = a + nx + 1, d = c + 1;
        quad.mesh.indices.insert(quad.mesh.indices.end(), {a, c, b, b, c, d});
      }
    quad.mesh.texture = checker_texture();
    scene.nodes.push_back(std::move(quad));
  }
  {
    SceneNode tris;
    tris.name = "coloured_triangles";
    Eigen::Affine3d pose = Eigen::Translation3d(0.25, 0.05, 0.4) * Eigen::AngleAxisd(0.35, Eigen::Vector3d::UnitY());
    tris.to_world = pose.matrix();
    const Rgb8 red{230, 30, 30}, green{30, 200, 60}, blue{40, 60, 230}, yellow{240, 220, 40};
    auto add = [&](Eigen::Vector3f a, Eigen::Vector3f b, Eigen::Vector3f c, Rgb8 ca, Rgb8 cb, Rgb8 cc) {
      const std::uint32_t base = static_cast<std::uint32_t>(tris.mesh.positions.size());
      tris.mesh.positions.insert(tris.mesh.positions.end(), {a, b, c});
      tris.mesh.colors.insert(tris.mesh.colors.end(), {ca, cb, cc});
      tris.mesh.indices.insert(tris.mesh.indices.end(), {base, base + 1, base + 2});
    };
    add({0.0f, -0.4f, 1.2f}, {0.3f, 0.1f, 1.2f}, {-0.2f, 0.2f, 1.3f}, red, green, blue);
    add({-0.3f, 0.15f, 1.0f}, {0.1f, 0.3f, 1.1f}, {-0.25f, 0.45f, 1.0f}, yellow, yellow, yellow);
    add({0.2f, -0.3f, 1.6f}, {0.5f, -0.2f, 1.6f}, {0.4f, 0.3f, 1.7f}, blue, blue, green);
    scene.nodes.push_back(std::move(tris));
  }
  {
    SceneNode cloud;
    cloud.name = "point_cloud";
    for (int j = 0; j < 20; ++j)
      for (int i = 0; i < 20; ++i) {
        const float x = -0.6f + 0.03f * i, y = 0.15f + 0.02f * j;
        cloud.points.positions.emplace_back(x, y, 1.4f + 0.1f * std::sin(3.0f * x));
        cloud.points.colors.push_back(
            Rgb8{static_cast<std::uint8_t>(50 + 10 * i), static_cast<std::uint8_t>(250 - 10 * j), 120});
      }
    scene.nodes.push_back(std::move(cloud));
  }
  CaptureCamera cam;
  cam.intrinsics.fx = cam.intrinsics.fy = 300.0;
  cam.intrinsics.cx = 159.5;
  cam.intrinsics.cy = 119.5;
  cam.intrinsics.width = 320;
  cam.intrinsics.height = 240;
  scene.cameras.push_back(cam);
  return scene;
}

ViewCamera intrinsics_camera() { return ViewCamera::from_capture(synthetic_scene().cameras[0]); }

ViewCamera look_at_camera() {
  return ViewCamera::look_at({0.7, -0.5, 0.1}, {-0.1, 0.0, 1.7}, {0.0, -1.0, 0.0}, 60.0, 320, 240).value();
}

}  // namespace rgbdcast::test
