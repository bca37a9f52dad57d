#include "tests/gltf/sample_scenes.h"

#include <Eigen/Geometry>
#include <cmath>

namespace rgbdcast::test {

Image gradient_texture(int w, int h) {
  Image im = Image::make(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      auto* p = im.pixel(x, y);
      p[0] = static_cast<std::uint8_t>(255 * x / (w - 1));
      p[1] = static_cast<std::uint8_t>(255 * y / (h - 1));
      p[2] = static_cast<std::uint8_t>(128 + 100 * std::sin(0.05 * (x + y)));
    }
  return im;
}

static Mesh grid(int n, float z_m) {
  Mesh m;
  for (int y = 0; y <= n; ++y)
    for (int x = 0; x <= n; ++x) {
      const float u = float(x) / n, v = float(y) / n;
      m.positions.push_back({-0.5f + u, -0.4f + 0.8f * v, z_m + 0.3f * u * v});
      m.uvs.push_back({u, v});
      m.colors.push_back({static_cast<std::uint8_t>(255 * u), static_cast<std::uint8_t>(255 * v), 7});
    }
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const std::uint32_t i = y * (n + 1) + x, r = n + 1;
      m.indices.insert(m.indices.end(), {i, i + 1, i + r, i + 1, i + r + 1, i + r});
    }
  return m;
}

Mesh textured_grid(int n, float z_m) {
  Mesh m = grid(n, z_m);
  m.colors.clear();
  m.texture = gradient_texture(64, 48);
  return m;
}

Mesh coloured_grid(int n, float z_m) {
  Mesh m = grid(n, z_m);
  m.uvs.clear();
  return m;
}

Scene sample_scene() {
  Scene s;
  SceneNode a;
  a.name = "keyframe0";
  a.mesh = textured_grid(6, 1.5f);
  s.nodes.push_back(a);
  SceneNode b;
  b.name = "keyframe1";
  b.mesh = coloured_grid(4, 2.0f);
  b.points.positions = b.mesh.positions;
  b.points.colors = b.mesh.colors;
  Eigen::Affine3d t =
      Eigen::Translation3d(0.2, -0.1, 0.3) * Eigen::AngleAxisd(0.3, Eigen::Vector3d(0, 1, 0.2).normalized());
  b.to_world = t.matrix();
  s.nodes.push_back(b);
  // Atlas-like: every triangle has its own vertices (indices 0, 1, 2, ...) and UVs on texel corners.
  SceneNode c;
  c.name = "atlas_like";
  c.mesh.texture = gradient_texture(32, 16);
  for (int t = 0; t < 8; ++t) {
    const float x = 0.1f * t;
    c.mesh.positions.insert(c.mesh.positions.end(), {{x, 0, 1}, {x + 0.1f, 0, 1}, {x, 0.1f, 1.05f}});
    const float u0 = (t % 4) * 8.0f, v0 = (t / 4) * 8.0f;
    c.mesh.uvs.insert(c.mesh.uvs.end(),
                      {{(u0 + 1) / 32, (v0 + 1) / 16}, {(u0 + 4) / 32, (v0 + 1) / 16}, {(u0 + 1) / 32, (v0 + 4) / 16}});
    for (int k = 0; k < 3; ++k) c.mesh.indices.push_back(static_cast<std::uint32_t>(3 * t + k));
  }
  s.nodes.push_back(c);
  CaptureCamera cam;
  cam.intrinsics.fx = 517.3;
  cam.intrinsics.fy = 516.5;
  cam.intrinsics.cx = 318.6;
  cam.intrinsics.cy = 255.3;
  cam.timestamp = 1305031102.175304;
  cam.source = "rgb/1305031102.175304.png";
  cam.frame_index = 0;
  s.cameras.push_back(cam);
  CaptureCamera cam2 = cam;
  cam2.camera_to_world = b.to_world;
  cam2.frame_index = 1;
  s.cameras.push_back(cam2);
  s.extras_json =
      R"({"intrinsics":{"fx":517.3},"timestamp":1305031102.175304,"source_frame":"rgb/1305031102.175304.png","stages":{"points":22474,"triangles":40168}})";
  return s;
}

}  // namespace rgbdcast::test
