// Spending texture bytes only on what is drawn: the texels no triangle samples (from the UVs), and their smooth fill.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "atlas/atlas.h"
#include "atlas/unsampled_fill.h"
#include "tests/atlas/checkerboard_scene.h"
#include "tests/atlas/right_triangle_mesh.h"
#include "tests/common/test_data.h"

using namespace rgbdcast;

TEST(UnsampledFill, MarksExactlyTheTexelsABilinearLookupReads) {
  // One triangle in a 16x8 texture, in texel units (0,0)-(8,0)-(0,8) scaled to UVs.
  Mesh m;
  m.positions = {{0, 0, 1}, {1, 0, 1}, {0, 1, 1}};
  m.uvs = {{2.0f / 16, 2.0f / 8}, {6.0f / 16, 2.0f / 8}, {2.0f / 16, 6.0f / 8}};
  m.indices = {0, 1, 2};
  auto mask = texels_sampled_by_uvs(m, 16, 8);
  ASSERT_TRUE(mask.ok());
  // Brute force: densely sample the triangle and mark the texels each bilinear lookup reads (clamped) with a weight.
  std::vector<std::uint8_t> ref(16 * 8, 0);
  const int N = 400;
  for (int a = 0; a <= N; ++a)
    for (int b = 0; a + b <= N; ++b) {
      const double x = 2 + 4.0 * a / N, y = 2 + 4.0 * b / N;
      const int xa = int(std::floor(x - 0.5)), ya = int(std::floor(y - 0.5));
      const double wx = x - 0.5 - xa, wy = y - 0.5 - ya;
      for (int n = 0; n < 4; ++n) {
        if (((n & 1) ? wx : 1 - wx) * ((n >> 1) ? wy : 1 - wy) < 1e-3) continue;
        const int tx = std::clamp(xa + (n & 1), 0, 15), ty = std::clamp(ya + (n >> 1), 0, 7);
        ref[ty * 16 + tx] = 1;
      }
    }
  int extra = 0, missing = 0;
  for (size_t i = 0; i < ref.size(); ++i) {
    extra += (*mask)[i] && !ref[i];
    missing += !(*mask)[i] && ref[i];
  }
  EXPECT_EQ(missing, 0) << "the mask must hold every texel a lookup reads";
  EXPECT_LE(extra, 3) << "and little more (texels whose square the triangle only touches)";
  // A triangle beyond the left border reads the border column (CLAMP_TO_EDGE).
  m.uvs = {{-1.0f, 0.3f}, {-0.5f, 0.3f}, {-1.0f, 0.6f}};
  auto left = texels_sampled_by_uvs(m, 16, 8);
  ASSERT_TRUE(left.ok());
  int marked = 0;
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 16; ++x) {
      marked += (*left)[y * 16 + x];
      if (x > 0) {
        EXPECT_EQ((*left)[y * 16 + x], 0);
      }
    }
  EXPECT_GT(marked, 0);
  m.uvs.pop_back();
  EXPECT_FALSE(texels_sampled_by_uvs(m, 16, 8).ok());
  EXPECT_FALSE(texels_sampled_by_uvs(Mesh{}, 0, 8).ok());
}

TEST(UnsampledFill, KeepsSampledTexelsAndContinuesThemSmoothly) {
  // A smooth ramp with a big unsampled hole and scattered unsampled texels.
  Image img = Image::make(96, 64, 3);
  std::vector<std::uint8_t> sampled(96 * 64, 1);
  std::mt19937 rng(1);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 96; ++x) {
      std::uint8_t* p = img.pixel(x, y);
      p[0] = static_cast<std::uint8_t>(40 + 2 * x);
      p[1] = static_cast<std::uint8_t>(30 + 3 * y);
      p[2] = 100;
      const bool hole = (x - 40) * (x - 40) + (y - 30) * (y - 30) < 15 * 15 || rng() % 10 == 0;
      if (hole) {
        sampled[y * 96 + x] = 0;
        p[0] = p[1] = p[2] = 0;  // what an empty atlas holds
      }
    }
  const Image before = img;
  ASSERT_TRUE(fill_unsampled_texels(&img, sampled));
  int changed = 0, holes = 0;
  double worst = 0;
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 96; ++x) {
      const std::uint8_t* a = before.pixel(x, y);
      const std::uint8_t* b = img.pixel(x, y);
      if (sampled[y * 96 + x]) {
        ASSERT_TRUE(a[0] == b[0] && a[1] == b[1] && a[2] == b[2]) << "sampled texel " << x << "," << y << " changed";
        continue;
      }
      ++holes;
      changed += a[0] != b[0] || a[1] != b[1] || a[2] != b[2];
      // The ramp continued: near the true ramp (push-pull is smooth, not linear, and whole 8x8 blocks without a sampled
      // texel are flat, i.e. up to ~4 texels x 3 levels off on this ramp).
      worst =
          std::max({worst, std::abs(b[0] - (40.0 + 2 * x)), std::abs(b[1] - (30.0 + 3 * y)), std::abs(b[2] - 100.0)});
    }
  std::printf("%d unsampled texels, %d changed, worst distance from the ramp %.1f levels\n", holes, changed, worst);
  EXPECT_EQ(changed, holes);
  EXPECT_LT(worst, 32.0);
  // Nothing sampled at all: mid-grey.
  std::vector<std::uint8_t> none(96 * 64, 0);
  ASSERT_TRUE(fill_unsampled_texels(&img, none));
  EXPECT_EQ(img.pixel(5, 5)[0], 128);
  EXPECT_FALSE(fill_unsampled_texels(&img, std::vector<std::uint8_t>(10, 0)));
  Image gray = Image::make(4, 4, 1);
  EXPECT_FALSE(fill_unsampled_texels(&gray, std::vector<std::uint8_t>(16, 0)));
}

// In both atlas layouts that use it: texels a triangle samples keep their bytes, the rest change, and the JPEG gets
// smaller.
TEST(UnsampledFill, FootprintAndFrameTexturesChangeOnlyWhatNoTriangleSamples) {
  test::CheckerScene sc = test::make_checker_scene(60.0, 1, 1);
  sc.mesh = test::checker_right_triangle_mesh(sc, 8, 64);
  for (TextureMode mode : {TextureMode::kFootprint, TextureMode::kFrame}) {
    AtlasOptions on, off;
    on.mode = off.mode = mode;
    on.fill_unsampled = true;
    off.fill_unsampled = false;
    auto a = build_atlas(sc.mesh, sc.image, sc.k, on), b = build_atlas(sc.mesh, sc.image, sc.k, off);
    ASSERT_TRUE(a.ok() && b.ok());
    ASSERT_EQ(a->width, b->width);
    ASSERT_EQ(a->height, b->height);
    auto mask = texels_sampled_by_uvs(a->mesh, a->width, a->height);
    ASSERT_TRUE(mask.ok());
    size_t sampled_same = 0, sampled = 0, unsampled_changed = 0;
    for (int y = 0; y < a->height; ++y)
      for (int x = 0; x < a->width; ++x) {
        const std::uint8_t* p = a->mesh.texture.pixel(x, y);
        const std::uint8_t* q = b->mesh.texture.pixel(x, y);
        const bool same = p[0] == q[0] && p[1] == q[1] && p[2] == q[2];
        if ((*mask)[static_cast<size_t>(y) * a->width + x]) {
          ++sampled;
          sampled_same += same;
        } else {
          unsampled_changed += !same;
        }
      }
    std::printf(
        "%s: %zu triangles, %dx%d, %zu texels sampled, %zu unsampled filled (%zu changed), fill %.2f ms; "
        "JPEG q85 %zu B filled vs %zu B not\n",
        to_string(mode), a->triangles, a->width, a->height, sampled, a->unsampled_texels, unsampled_changed, a->fill_ms,
        a->mesh.texture_encoded.size(), b->mesh.texture_encoded.size());
    EXPECT_EQ(sampled_same, sampled) << to_string(mode);
    EXPECT_GT(a->unsampled_texels, 0u);
    EXPECT_GT(unsampled_changed, 0u);
    EXPECT_EQ(b->unsampled_texels, 0u);
    EXPECT_LT(a->mesh.texture_encoded.size(), b->mesh.texture_encoded.size()) << to_string(mode);
  }
}

// On a real frame (TUM fr1/xyz frame 0, its images as stored, meshed with the RTIN stand-in): the fill leaves every
// texel a triangle reads as it was and makes the texture's JPEG smaller in both modes, at q50 and q85.
TEST(UnsampledFill, RealFrameJpegIsSmallerWithTheFill) {
  const std::string dir = "tum/rgbd_dataset_freiburg1_xyz";
  REQUIRE_DATA(dir + "/rgb/1305031102.175304.png");
  const cv::Mat bgr = cv::imread(test::data_path(dir + "/rgb/1305031102.175304.png"), cv::IMREAD_COLOR);
  const cv::Mat raw = cv::imread(test::data_path(dir + "/depth/1305031102.160407.png"), cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(bgr.empty());
  ASSERT_EQ(raw.type(), CV_16UC1);
  cv::Mat rgb, depth;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  raw.convertTo(depth, CV_32F, 1.0 / 5000.0);
  Intrinsics k;  // fr1, pinhole (the images as stored: the lens distortion is the same for mesh and texture here)
  k.fx = 517.3;
  k.fy = 516.5;
  k.cx = 318.6;
  k.cy = 255.3;
  k.width = 640;
  k.height = 480;
  const Mesh mesh = test::right_triangle_mesh_of_depth(depth, k, 16.0);
  ASSERT_GT(mesh.triangle_count(), 5000u);
  for (TextureMode mode : {TextureMode::kFootprint, TextureMode::kFrame})
    for (int q : {50, 85}) {
      AtlasOptions on, off;
      on.mode = off.mode = mode;
      on.jpeg_quality = off.jpeg_quality = q;
      on.fill_unsampled = true;
      off.fill_unsampled = false;
      auto a = build_atlas(mesh, rgb, k, on), b = build_atlas(mesh, rgb, k, off);
      ASSERT_TRUE(a.ok() && b.ok());
      auto mask = texels_sampled_by_uvs(a->mesh, a->width, a->height);
      ASSERT_TRUE(mask.ok());
      size_t differ = 0;
      for (size_t i = 0; i < mask->size(); ++i)
        if ((*mask)[i])
          differ += !std::equal(a->mesh.texture.data.begin() + 3 * i, a->mesh.texture.data.begin() + 3 * i + 3,
                                b->mesh.texture.data.begin() + 3 * i);
      std::printf(
          "TUM fr1/xyz 0, %zu triangles, %s %dx%d, q%d: JPEG %zu B with the fill, %zu B without (%.1f%%); "
          "%zu texels unsampled\n",
          a->triangles, to_string(mode), a->width, a->height, q, a->mesh.texture_encoded.size(),
          b->mesh.texture_encoded.size(),
          100.0 * (double(a->mesh.texture_encoded.size()) / b->mesh.texture_encoded.size() - 1), a->unsampled_texels);
      EXPECT_EQ(differ, 0u);
      EXPECT_LT(a->mesh.texture_encoded.size(), b->mesh.texture_encoded.size());
    }
}
