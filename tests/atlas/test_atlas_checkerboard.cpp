// A planar checkerboard whose normal is 60 degrees off the optical axis, meshed with a few large triangles, textured
// both ways. Rendering a triangle means interpolating its UVs over it (perspective-correct: linearly in the 3D
// point's barycentric coordinates) and reading the texture. We measure, at points spread over every triangle:
//  - geometric error: the plane point the texture lookup actually shows vs the true point (mm);
//  - texture error: the fraction of points (away from checker edges) whose texture colour is the wrong square.
// The atlas is exact up to resampling; the frame baseline bends the checker edges inside each triangle.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cstdio>

#include "atlas/atlas.h"
#include "atlas/frame_texture.h"
#include "atlas/triangle_homography.h"
#include "tests/atlas/checkerboard_scene.h"

using namespace rgbdcast;

namespace {

struct TextureErrors {
  double max_shift_mm = 0;
  double wrong_square_fraction = 0;
  int samples = 0;
};

double texture_value(const Image& tex, const Eigen::Vector2d& uv) {
  cv::Mat view(tex.height, tex.width, CV_8UC3, const_cast<std::uint8_t*>(tex.data.data()));
  std::uint8_t px[3];
  atlas_detail::sample_bilinear(view, uv.x() * tex.width - 0.5, uv.y() * tex.height - 0.5, px);
  return px[0];
}

TextureErrors measure(const test::CheckerScene& sc, const AtlasResult& r) {
  TextureErrors e;
  int wrong = 0, counted = 0;
  const Mesh& m = r.mesh;
  const Eigen::Vector2d size(m.texture.width, m.texture.height);
  for (size_t t = 0; t < m.triangle_count(); ++t) {
    std::array<Eigen::Vector3d, 3> v;
    std::array<Eigen::Vector2d, 3> uv;
    for (int i = 0; i < 3; ++i) {
      v[i] = m.positions[m.indices[3 * t + i]].cast<double>();
      uv[i] = m.uvs[m.indices[3 * t + i]].cast<double>();
    }
    // Where the texture's texels came from in the image: the frame texture is the image itself; the atlas cell's
    // map is recovered from its corners (same function the atlas used).
    TriangleTextureMap map;
    if (r.mode == TextureMode::kAtlas) {
      std::array<Eigen::Vector2d, 3> corners;
      for (int i = 0; i < 3; ++i) corners[i] = uv[i].cwiseProduct(size);
      EXPECT_TRUE(triangle_texture_map(v[0], v[1], v[2], sc.k.K(), corners, &map));
    }
    const int N = 40;
    for (int a = 0; a <= N; ++a)
      for (int b = 0; a + b <= N; ++b) {
        const double b1 = double(a) / N, b2 = double(b) / N, b0 = 1 - b1 - b2;
        const Eigen::Vector3d X = b0 * v[0] + b1 * v[1] + b2 * v[2];
        const Eigen::Vector2d q = b0 * uv[0] + b1 * uv[1] + b2 * uv[2];
        Eigen::Vector2d image_px;
        if (r.mode == TextureMode::kAtlas) {
          const Eigen::Vector3d h = map.image_from_atlas * Eigen::Vector3d(q.x() * size.x(), q.y() * size.y(), 1);
          image_px = h.head<2>() / h.z();
        } else {
          image_px = q.cwiseProduct(size) - Eigen::Vector2d(0.5, 0.5);
        }
        const Eigen::Vector2d st_true = sc.plane_of(X);
        const Eigen::Vector2d st_shown = sc.plane_at_pixel(image_px.x(), image_px.y());
        e.max_shift_mm = std::max(e.max_shift_mm, 1000.0 * (st_shown - st_true).norm());
        ++e.samples;
        if (sc.edge_distance_m(st_true.x(), st_true.y()) < 0.008) continue;
        ++counted;
        const int shown = texture_value(m.texture, q) > 127.5 ? 1 : 0;
        if (shown != sc.checker(st_true.x(), st_true.y())) ++wrong;
      }
  }
  e.wrong_square_fraction = counted ? double(wrong) / counted : 1.0;
  return e;
}

}  // namespace

TEST(AtlasCheckerboard, AtlasKeepsCheckerEdgesStraightWhereFrameTextureBendsThem) {
  const test::CheckerScene sc = test::make_checker_scene(60.0, 3, 2);
  AtlasOptions atlas_opt;
  atlas_opt.cell_size_px = 128;  // large triangles: a cell resolution near the image's
  auto atlas = build_atlas(sc.mesh, sc.image, sc.k, atlas_opt);
  ASSERT_TRUE(atlas.ok()) << atlas.error().message;
  AtlasOptions frame_opt;
  frame_opt.mode = TextureMode::kFrame;
  auto frame = build_atlas(sc.mesh, sc.image, sc.k, frame_opt);
  ASSERT_TRUE(frame.ok()) << frame.error().message;

  const TextureErrors ea = measure(sc, atlas.value()), ef = measure(sc, frame.value());
  std::printf("60 deg checkerboard, %zu triangles: atlas %dx%d max shift %.3f mm, wrong squares %.4f; "
              "frame max shift %.1f mm, wrong squares %.4f\n",
              sc.mesh.triangle_count(), atlas->width, atlas->height, ea.max_shift_mm, ea.wrong_square_fraction,
              ef.max_shift_mm, ef.wrong_square_fraction);
  EXPECT_LT(ea.max_shift_mm, 0.01);           // exact map (floating point)
  EXPECT_LT(ea.wrong_square_fraction, 0.002); // resampling only, away from edges
  EXPECT_GT(ef.max_shift_mm, 10.0);           // the affine baseline is off by centimetres inside big triangles
  EXPECT_GT(ef.wrong_square_fraction, 0.02);
  EXPECT_GT(ef.wrong_square_fraction, 10 * ea.wrong_square_fraction);
}

TEST(AtlasCheckerboard, FrontoParallelBoardIsExactInBothModes) {
  // Control: with the board facing the camera, affine = projective, so the baseline is exact too.
  const test::CheckerScene sc = test::make_checker_scene(0.0, 3, 2);
  AtlasOptions fo;
  fo.mode = TextureMode::kFrame;
  auto frame = build_atlas(sc.mesh, sc.image, sc.k, fo);
  ASSERT_TRUE(frame.ok());
  const TextureErrors ef = measure(sc, frame.value());
  EXPECT_LT(ef.max_shift_mm, 0.01);
  EXPECT_LT(ef.wrong_square_fraction, 0.002);
}
