// A planar checkerboard whose normal is 60 degrees off the optical axis, meshed with a few large triangles, textured
// both ways. Rendering a triangle means interpolating its UVs over it (perspective-correct: linearly in the 3D
// point's barycentric coordinates) and reading the texture. We measure, at points spread over every triangle:
//  - geometric error: the plane point the texture lookup actually shows vs the true point (mm);
//  - texture error: the fraction of points (away from checker edges) whose texture colour is the wrong square.
// The atlas is exact up to resampling; the frame baseline bends the checker edges inside each triangle.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cstdio>

#include "atlas/atlas.h"
#include "atlas/frame_texture.h"
#include "atlas/triangle_homography.h"
#include "tests/atlas/barycentric.h"
#include "tests/atlas/checkerboard_scene.h"

using namespace rgbdcast;

namespace {

struct TextureErrors {
  double max_shift_mm = 0;
  double max_shift_px = 0;  // the image point the lookup shows vs where the surface point projects
  size_t patch_triangles = 0;
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
    Eigen::Vector2d patch_shift;  // footprint triangles textured from a frame patch: atlas = image + shift
    std::array<Eigen::Vector2d, 3> q_texels;
    for (int i = 0; i < 3; ++i) q_texels[i] = uv[i].cwiseProduct(size);
    const bool patch =
        r.mode == TextureMode::kFootprint && test::is_patch_triangle(q_texels, v, sc.k.K(), &patch_shift);
    e.patch_triangles += patch;
    if (r.mode != TextureMode::kFrame && !patch) {
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
        if (patch) {
          image_px = q.cwiseProduct(size) - patch_shift;
        } else if (r.mode != TextureMode::kFrame) {
          const Eigen::Vector3d h = map.image_from_atlas * Eigen::Vector3d(q.x() * size.x(), q.y() * size.y(), 1);
          image_px = h.head<2>() / h.z();
        } else {
          image_px = q.cwiseProduct(size) - Eigen::Vector2d(0.5, 0.5);
        }
        const Eigen::Vector2d st_true = sc.plane_of(X);
        const Eigen::Vector2d st_shown = sc.plane_at_pixel(image_px.x(), image_px.y());
        e.max_shift_mm = std::max(e.max_shift_mm, 1000.0 * (st_shown - st_true).norm());
        e.max_shift_px = std::max(e.max_shift_px, (image_px - sc.k.project(X)).norm());
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

// The scene's mesh textured in `mode` (fixed cells of cell_px for kAtlas; frame patches for kFootprint's triangles
// within patch_px of projective); a failure is recorded, and then the result is empty.
AtlasResult textured(const test::CheckerScene& sc, TextureMode mode, int cell_px = 8, double patch_px = 0.25) {
  AtlasOptions o;
  o.mode = mode;
  o.cell_size_px = cell_px;
  o.footprint_patch_deviation_px = patch_px;
  auto r = build_atlas(sc.mesh, sc.image, sc.k, o);
  if (!r.ok()) {
    ADD_FAILURE() << to_string(mode) << ": " << r.error().message;
    return {};
  }
  return std::move(r.value());
}

}  // namespace

TEST(AtlasCheckerboard, AtlasKeepsCheckerEdgesStraightWhereFrameTextureBendsThem) {
  const test::CheckerScene sc = test::make_checker_scene(60.0, 3, 2);
  // Large triangles: a cell resolution near the image's.
  const AtlasResult atlas = textured(sc, TextureMode::kAtlas, 128), frame = textured(sc, TextureMode::kFrame);
  ASSERT_GT(atlas.triangles, 0u);
  ASSERT_GT(frame.triangles, 0u);
  const TextureErrors ea = measure(sc, atlas), ef = measure(sc, frame);
  std::printf(
      "60 deg checkerboard, %zu triangles: atlas %dx%d max shift %.3f mm, wrong squares %.4f; "
      "frame max shift %.1f mm, wrong squares %.4f\n",
      sc.mesh.triangle_count(), atlas.width, atlas.height, ea.max_shift_mm, ea.wrong_square_fraction, ef.max_shift_mm,
      ef.wrong_square_fraction);
  EXPECT_LT(ea.max_shift_mm, 0.01);            // exact map (floating point)
  EXPECT_LT(ea.wrong_square_fraction, 0.002);  // resampling only, away from edges
  EXPECT_GT(ef.max_shift_mm, 10.0);            // the affine baseline is off by centimetres inside big triangles
  EXPECT_GT(ef.wrong_square_fraction, 0.02);
  EXPECT_GT(ef.wrong_square_fraction, 10 * ea.wrong_square_fraction);
}

TEST(AtlasCheckerboard, FrontoParallelBoardIsExactInBothModes) {
  // Control: with the board facing the camera, affine = projective, so the baseline is exact too.
  const test::CheckerScene sc = test::make_checker_scene(0.0, 3, 2);
  const AtlasResult frame = textured(sc, TextureMode::kFrame);
  ASSERT_GT(frame.triangles, 0u);
  const TextureErrors ef = measure(sc, frame);
  EXPECT_LT(ef.max_shift_mm, 0.01);
  EXPECT_LT(ef.wrong_square_fraction, 0.002);
}

// The realtime preset's shape of mesh: right isosceles triangles in image space with legs of 16-64 px (mixed), on the
// 60-degree board. The footprint atlas stays exact (well within 0.5 px) at about one texel per source pixel; the
// frame texture bends the checker edges inside the large triangles.
TEST(AtlasCheckerboard, FootprintAtlasOnLargeRightTrianglesIsUndistorted) {
  test::CheckerScene sc = test::make_checker_scene(60.0, 1, 1, 0.9, 0.8);  // the board fills the view
  sc.mesh = test::checker_right_triangle_mesh(sc, 16, 64);
  double min_leg = 1e9, max_leg = 0;
  for (size_t t = 0; t < sc.mesh.triangle_count(); ++t) {
    std::array<Eigen::Vector2d, 3> px;
    for (int i = 0; i < 3; ++i) px[i] = sc.k.project(sc.mesh.positions[sc.mesh.indices[3 * t + i]].cast<double>());
    std::array<double, 3> side = {(px[1] - px[0]).norm(), (px[2] - px[0]).norm(), (px[2] - px[1]).norm()};
    std::sort(side.begin(), side.end());  // legs, then the hypotenuse
    min_leg = std::min(min_leg, side[0]);
    max_leg = std::max(max_leg, side[1]);
  }
  ASSERT_GT(sc.mesh.triangle_count(), 100u);
  EXPECT_GE(min_leg, 16.0 - 1e-3);
  EXPECT_LE(max_leg, 64.0 + 1e-3);

  const AtlasResult fp = textured(sc, TextureMode::kFootprint, 8, 0.0), frame = textured(sc, TextureMode::kFrame),
                    patched = textured(sc, TextureMode::kFootprint);
  ASSERT_GT(fp.triangles, 0u);
  ASSERT_GT(frame.triangles, 0u);
  ASSERT_GT(patched.triangles, 0u);
  const TextureErrors ea = measure(sc, fp), ef = measure(sc, frame), ep = measure(sc, patched);
  std::printf(
      "60 deg checkerboard, %zu right triangles (legs %.1f-%.1f px): footprint %dx%d (packing %.3f) max shift "
      "%.4f mm / %.2g px, wrong squares %.4f; frame max shift %.2f mm / %.2f px, wrong squares %.4f; "
      "footprint with frame patches (%zu triangles) %dx%d max shift %.2f mm / %.3f px, wrong squares %.4f\n",
      sc.mesh.triangle_count(), min_leg, max_leg, fp.width, fp.height, fp.packing_efficiency, ea.max_shift_mm,
      ea.max_shift_px, ea.wrong_square_fraction, ef.max_shift_mm, ef.max_shift_px, ef.wrong_square_fraction,
      ep.patch_triangles, patched.width, patched.height, ep.max_shift_mm, ep.max_shift_px, ep.wrong_square_fraction);
  EXPECT_EQ(fp.triangles, sc.mesh.triangle_count());
  EXPECT_EQ(ea.patch_triangles, 0u);
  EXPECT_LT(ea.max_shift_px, 0.5);
  EXPECT_LT(ea.max_shift_px, 1e-3) << "the map is exact up to rounding";
  EXPECT_LT(ea.max_shift_mm, 0.01);
  EXPECT_LT(ea.wrong_square_fraction, 0.002);
  EXPECT_GT(ef.max_shift_px, 0.5);  // the affine baseline misses the 0.5 px target on these triangles
  EXPECT_GT(ef.wrong_square_fraction, 5 * std::max(ea.wrong_square_fraction, 1e-4));
  EXPECT_LT(ep.max_shift_px, 0.5);  // patches only where the frame mapping is within 0.25 px
  EXPECT_LT(ep.wrong_square_fraction, 0.002);
  // About one texel per source pixel: the atlas holds about as many texels as the triangles cover pixels.
  double source_px = 0;
  for (size_t t = 0; t < sc.mesh.triangle_count(); ++t)
    source_px += projected_area_px(sc.mesh.positions[sc.mesh.indices[3 * t]].cast<double>(),
                                   sc.mesh.positions[sc.mesh.indices[3 * t + 1]].cast<double>(),
                                   sc.mesh.positions[sc.mesh.indices[3 * t + 2]].cast<double>(), sc.k.K());
  const double triangle_texels = fp.packing_efficiency * double(fp.texels);
  EXPECT_GT(triangle_texels, 0.99 * source_px);
  EXPECT_LT(triangle_texels, 1.25 * source_px);
}
