// The per-triangle maps and the cell layout: a texel maps back (M^-1) to where its 3D point projects; bilinear
// lookups inside a triangle never touch a texel owned by another triangle.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "atlas/atlas.h"
#include "atlas/atlas_layout.h"
#include "atlas/triangle_homography.h"
#include "tests/atlas/barycentric.h"

using namespace rgbdcast;

namespace {

Eigen::Matrix3d kinect_K() {
  Intrinsics k;
  k.fx = 517.3;
  k.fy = 516.5;
  k.cx = 318.6;
  k.cy = 255.3;
  return k.K();
}

}  // namespace

TEST(AtlasMath, TexelMapsBackToTheProjectionOfItsPoint) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uni(-1, 1), depth(0.5, 4.0), size(0.01, 0.8), unit(0, 1);
  const Eigen::Matrix3d K = kinect_K();
  CellLayout layout;
  ASSERT_TRUE(make_cell_layout(1000, 16, 1, true, 8192, &layout));
  double worst_px = 0;
  int maps = 0;
  for (int trial = 0; trial < 1000; ++trial) {
    // A random pose: a centre in the view frustum and a random orientation; a random triangle around it.
    const Eigen::Vector3d centre(uni(rng) * 1.5, uni(rng) * 1.0, depth(rng));
    const Eigen::Matrix3d R =
        Eigen::Quaterniond(Eigen::Vector4d(uni(rng), uni(rng), uni(rng), uni(rng)).normalized()).toRotationMatrix();
    const double s = size(rng);
    std::array<Eigen::Vector3d, 3> v;
    for (auto& p : v) p = centre + R * Eigen::Vector3d(uni(rng) * s, uni(rng) * s, 0.1 * s * uni(rng));
    if (v[0].z() < 0.1 || v[1].z() < 0.1 || v[2].z() < 0.1) continue;
    const size_t slot = trial % 1000;
    const auto corners = layout.corners(slot);
    TriangleTextureMap map;
    if (!triangle_texture_map(v[0], v[1], v[2], K, corners, &map)) continue;
    ++maps;
    // Vertices land on the corners.
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d at = map.A * Eigen::Vector3d(map.plane[i].x(), map.plane[i].y(), 1);
      EXPECT_LT((at.head<2>() - corners[i]).norm(), 1e-9);
    }
    for (int k = 0; k < 50; ++k) {
      double a = unit(rng), b = unit(rng);
      if (a + b > 1) a = 1 - a, b = 1 - b;
      const Eigen::Vector2d q = corners[0] + a * (corners[1] - corners[0]) + b * (corners[2] - corners[0]);
      const Eigen::Vector3d bc = test::barycentric(q, corners);
      const Eigen::Vector3d X = bc[0] * v[0] + bc[1] * v[1] + bc[2] * v[2];
      const Eigen::Vector3d proj = K * X;
      const Eigen::Vector3d back = map.image_from_atlas * Eigen::Vector3d(q.x(), q.y(), 1);
      const double err = (proj.head<2>() / proj.z() - back.head<2>() / back.z()).norm();
      worst_px = std::max(worst_px, err);
    }
  }
  EXPECT_GT(maps, 900);
  EXPECT_LT(worst_px, 0.5);
  EXPECT_LT(worst_px, 1e-6) << "the map is exact up to rounding";
}

TEST(AtlasMath, DegenerateAndBehindTheCameraAreRejected) {
  const Eigen::Matrix3d K = kinect_K();
  const std::array<Eigen::Vector2d, 3> c = {Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 0), Eigen::Vector2d(0, 1)};
  TriangleTextureMap m;
  EXPECT_FALSE(triangle_texture_map({0, 0, 1}, {1, 0, 1}, {2, 0, 1}, K, c, &m));   // collinear
  EXPECT_FALSE(triangle_texture_map({0, 0, 1}, {0, 0, 1}, {0, 1, 1}, K, c, &m));   // repeated vertex
  EXPECT_FALSE(triangle_texture_map({0, 0, -1}, {1, 0, 1}, {0, 1, 1}, K, c, &m));  // behind the camera
  EXPECT_TRUE(triangle_texture_map({0, 0, 1}, {1, 0, 1}, {0, 1, 1}, K, c, &m));
}

// For every slot of a layout with gutter 1, a bilinear lookup at any point inside the triangle reads only texels of
// the same cell half; with gutter 0 some lookups do reach a neighbour (that is what the gutter is for).
static double foreign_weight(int gutter, bool two_per_cell) {
  CellLayout l;
  EXPECT_TRUE(make_cell_layout(64, 8, gutter, two_per_cell, 8192, &l));
  auto owner = [&](int x, int y) -> long {
    if (x < 0 || y < 0 || x >= l.width || y >= l.height) return -1;
    const long cell = (y / l.cell_px) * l.columns + x / l.cell_px;
    if (!l.two_per_cell) return cell;
    const int i = x % l.cell_px, j = y % l.cell_px;
    return 2 * cell + ((i + j + 1 < l.cell_px) ? 0 : 1);
  };
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> unit(0, 1);
  double worst = 0;
  for (size_t slot = 0; slot < 64; ++slot) {
    const auto c = l.corners(slot);
    for (int k = 0; k < 400; ++k) {
      double a = unit(rng), b = unit(rng);
      if (a + b > 1) a = 1 - a, b = 1 - b;
      const Eigen::Vector2d q = c[0] + a * (c[1] - c[0]) + b * (c[2] - c[0]);
      // Bilinear: texel centres at i + 0.5.
      const double fx = q.x() - 0.5, fy = q.y() - 0.5;
      const int x0 = static_cast<int>(std::floor(fx)), y0 = static_cast<int>(std::floor(fy));
      const double wx = fx - x0, wy = fy - y0;
      double foreign = 0;
      const double w[4] = {(1 - wx) * (1 - wy), wx * (1 - wy), (1 - wx) * wy, wx * wy};
      const int dx[4] = {0, 1, 0, 1}, dy[4] = {0, 0, 1, 1};
      for (int t = 0; t < 4; ++t)
        if (owner(x0 + dx[t], y0 + dy[t]) != static_cast<long>(slot)) foreign += w[t];
      worst = std::max(worst, foreign);
    }
  }
  return worst;
}

TEST(AtlasLayout, GutterKeepsBilinearLookupsInsideTheirTriangle) {
  EXPECT_EQ(foreign_weight(1, true), 0.0);
  EXPECT_EQ(foreign_weight(2, true), 0.0);
  EXPECT_EQ(foreign_weight(1, false), 0.0);
  EXPECT_GT(foreign_weight(0, true), 0.2);
}

TEST(AtlasLayout, TwoTrianglesPerCellHalveTheAtlas) {
  CellLayout one, two;
  ASSERT_TRUE(make_cell_layout(10000, 8, 1, false, 8192, &one));
  ASSERT_TRUE(make_cell_layout(10000, 8, 1, true, 8192, &two));
  const double ratio = double(two.width) * two.height / (double(one.width) * one.height);
  EXPECT_NEAR(ratio, 0.5, 0.02);
  CellLayout bad;
  EXPECT_FALSE(make_cell_layout(10, 4, 1, true, 8192, &bad));         // no room for a triangle
  EXPECT_FALSE(make_cell_layout(10000000, 64, 1, true, 8192, &bad));  // too large
}

TEST(Atlas, BadInputIsAnErrorNotACrash) {
  Intrinsics k;
  cv::Mat img(480, 640, CV_8UC3, cv::Scalar(10, 20, 30));
  Mesh m;
  m.positions = {{0, 0, 1}, {0.1f, 0, 1}, {0, 0.1f, 1}};
  m.indices = {0, 1, 2};
  EXPECT_TRUE(build_atlas(m, img, k).ok());
  Mesh bad = m;
  bad.indices = {0, 1, 7};
  EXPECT_EQ(build_atlas(bad, img, k).error().code, ErrorCode::kInvalidArgument);
  bad = m;
  bad.indices = {0, 1};
  EXPECT_EQ(build_atlas(bad, img, k).error().code, ErrorCode::kInvalidArgument);
  bad = m;
  bad.positions[1].x() = NAN;
  EXPECT_EQ(build_atlas(bad, img, k).error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(build_atlas(Mesh{}, img, k).error().code, ErrorCode::kEmpty);
  EXPECT_EQ(build_atlas(m, cv::Mat(480, 640, CV_8UC1), k).error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(build_atlas(m, cv::Mat(240, 320, CV_8UC3), k).error().code, ErrorCode::kInvalidArgument);
  AtlasOptions o;
  o.cell_size_px = 2;
  EXPECT_EQ(build_atlas(m, img, k, o).error().code, ErrorCode::kInvalidArgument);
  o = {};
  o.jpeg_quality = 0;
  EXPECT_EQ(build_atlas(m, img, k, o).error().code, ErrorCode::kInvalidArgument);
  bad = m;
  for (auto& p : bad.positions) p.z() = -1;
  EXPECT_EQ(build_atlas(bad, img, k).error().code, ErrorCode::kEmpty);
  EXPECT_FALSE(parse_texture_mode("cube").ok());
  EXPECT_EQ(parse_texture_mode("frame").value(), TextureMode::kFrame);
}

TEST(Atlas, OutputMeshHasOwnVerticesPerTriangleAndUvsInsideTheAtlas) {
  Intrinsics k;
  cv::Mat img(480, 640, CV_8UC3);
  cv::randu(img, 0, 255);
  Mesh m;
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 5; ++x) m.positions.push_back({-0.2f + 0.1f * x, -0.2f + 0.1f * y, 1.0f + 0.05f * x});
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x) {
      const std::uint32_t i = y * 5 + x;
      m.indices.insert(m.indices.end(), {i, i + 1, i + 5, i + 1, i + 6, i + 5});
    }
  auto r = build_atlas(m, img, k);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->triangles, 32u);
  EXPECT_EQ(r->cells, 16u);
  EXPECT_EQ(r->mesh.positions.size(), 96u);
  EXPECT_EQ(r->mesh.uvs.size(), 96u);
  EXPECT_EQ(r->mesh.texture.width, r->width);
  EXPECT_FALSE(r->mesh.texture_encoded.empty());
  EXPECT_EQ(r->mesh.texture_mime, "image/jpeg");
  for (const auto& uv : r->mesh.uvs) {
    EXPECT_GT(uv.x(), 0.0f);
    EXPECT_LT(uv.x(), 1.0f);
    EXPECT_GT(uv.y(), 0.0f);
    EXPECT_LT(uv.y(), 1.0f);
  }
  AtlasOptions f;
  f.mode = TextureMode::kFrame;
  auto fr = build_atlas(m, img, k, f);
  ASSERT_TRUE(fr.ok());
  EXPECT_EQ(fr->mesh.positions.size(), 25u);  // shared vertices kept
  EXPECT_EQ(fr->width, 640);
}

// auto: a mesh of large triangles (each covers thousands of pixels) gets the undistorted atlas; a fine mesh whose
// triangles cover a few pixels, as the 1 cm reduction makes, gets the frame texture.
TEST(Atlas, AutoPicksTheAtlasForLargeTrianglesAndTheFrameForTinyOnes) {
  cv::Mat rgb(480, 640, CV_8UC3, cv::Scalar(90, 120, 150));
  Intrinsics k;
  auto grid_mesh = [](int n, double half_width_m) {
    Mesh m;
    for (int y = 0; y <= n; ++y)
      for (int x = 0; x <= n; ++x)
        m.positions.emplace_back(float(-half_width_m + 2 * half_width_m * x / n),
                                 float(-half_width_m + 2 * half_width_m * y / n), 2.0f);
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const std::uint32_t a = y * (n + 1) + x, b = a + 1, c = a + n + 1, d = c + 1;
        m.indices.insert(m.indices.end(), {a, c, b, b, c, d});
      }
    m.colors.assign(m.positions.size(), Rgb8{1, 2, 3});
    return m;
  };
  AtlasOptions o;
  o.mode = TextureMode::kAuto;
  auto coarse = build_atlas(grid_mesh(4, 0.8), rgb, k, o);  // 32 triangles over ~400x400 px: ~2,500 px each
  ASSERT_TRUE(coarse) << coarse.error().message;
  EXPECT_EQ(coarse->mode, TextureMode::kAtlas);
  auto fine = build_atlas(grid_mesh(200, 0.8), rgb, k, o);  // 80,000 triangles: ~2 px each
  ASSERT_TRUE(fine) << fine.error().message;
  EXPECT_EQ(fine->mode, TextureMode::kFrame);
  EXPECT_STREQ(to_string(TextureMode::kAuto), "auto");
  EXPECT_TRUE(parse_texture_mode("auto"));
}
