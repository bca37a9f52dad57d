// The footprint atlas (TextureMode::kFootprint): size classes, packing (no overlap, inside the image, deterministic),
// the 0.5 px contract of every texel (texel -> M^-1 -> the pixel where its surface point projects), the gutter, and
// about one texel per source pixel.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <cstdio>
#include <map>
#include <random>

#include "atlas/atlas.h"
#include "atlas/footprint_layout.h"
#include "atlas/triangle_homography.h"
#include "tests/atlas/barycentric.h"
#include "tests/atlas/checkerboard_scene.h"
#include "tests/atlas/right_triangle_mesh.h"

using namespace rgbdcast;

namespace {

// A tilted, curved surface in front of a Kinect-like camera, meshed like the realtime preset's RTIN would mesh it:
// right isosceles triangles in image space with legs 1.4-64 px, finer where the surface bends.
struct CurvedScene {
  Intrinsics k;
  cv::Mat image;
  Mesh mesh;
};

CurvedScene make_curved_scene() {
  CurvedScene s;
  s.k.fx = 517.3;
  s.k.fy = 516.5;
  s.k.cx = 318.6;
  s.k.cy = 255.3;
  s.k.width = 640;
  s.k.height = 480;
  s.image.create(480, 640, CV_8UC3);
  cv::randu(s.image, 0, 255);
  cv::Mat depth(480, 640, CV_32F);
  for (int y = 0; y < 480; ++y)
    for (int x = 0; x < 640; ++x) {
      // A plane tilted ~50 degrees with a bump; no depth in a disc (a hole to mesh around).
      const double bump = 0.15 * std::exp(-((x - 420.0) * (x - 420.0) + (y - 200.0) * (y - 200.0)) / (2 * 60.0 * 60.0));
      const bool hole = (x - 150) * (x - 150) + (y - 350) * (y - 350) < 40 * 40;
      depth.at<float>(y, x) = hole ? 0.0f : static_cast<float>(1.0 + 0.004 * x - bump);
    }
  s.mesh = test::right_triangle_mesh_of_depth(depth, s.k, 0.2);
  return s;
}

std::array<Eigen::Vector2d, 3> corners_of(const AtlasResult& r, size_t t) {
  std::array<Eigen::Vector2d, 3> c;
  for (int i = 0; i < 3; ++i)
    c[i] = r.mesh.uvs[r.mesh.indices[3 * t + i]].cast<double>().cwiseProduct(Eigen::Vector2d(r.width, r.height));
  return c;
}

}  // namespace

TEST(FootprintLayout, SizeClassesFollowTheLegsOfARightTriangulation) {
  const std::vector<int> expected = {1, 2, 3, 4, 6, 8, 12, 16, 23, 32, 46, 64, 91, 128, 182, 256};
  EXPECT_EQ(footprint_leg_classes(), expected);
  // RTIN legs 2^k (axis-aligned) and 2^k sqrt 2 (diagonal) get the next whole texel.
  for (int k = 0; k <= 6; ++k) {
    EXPECT_EQ(footprint_leg_class(std::pow(2.0, k)), 1 << k) << k;
    EXPECT_EQ(footprint_leg_class(std::pow(2.0, k) * std::sqrt(2.0)),
              int(std::ceil(std::pow(2.0, k) * std::sqrt(2.0))));
  }
  EXPECT_EQ(footprint_leg_class(0.3), 1);
  EXPECT_EQ(footprint_leg_class(16.0005), 16);  // rounding slack
  EXPECT_EQ(footprint_leg_class(16.1), 23);
  EXPECT_EQ(footprint_leg_class(1e6), 256);
  // The footprint of a right isosceles image triangle is its leg, whichever vertex is listed first.
  int right = -1;
  const std::array<Eigen::Vector2d, 3> tri = {Eigen::Vector2d(40, 10), Eigen::Vector2d(10, 10),
                                              Eigen::Vector2d(10, 40)};
  EXPECT_NEAR(footprint_leg_px(tri, &right), 30.0, 1e-9);
  EXPECT_EQ(right, 1);
  const std::array<Eigen::Vector2d, 3> diag = {Eigen::Vector2d(0, 0), Eigen::Vector2d(8, 8), Eigen::Vector2d(16, 0)};
  EXPECT_NEAR(footprint_leg_px(diag, &right), 8 * std::sqrt(2.0), 1e-9);
  EXPECT_EQ(right, 1);
  // An obtuse triangle needs more than its longest adjacent edge, so that no direction gets under a texel per pixel.
  const std::array<Eigen::Vector2d, 3> obtuse = {Eigen::Vector2d(0, 0), Eigen::Vector2d(-10, 3),
                                                 Eigen::Vector2d(10, 3)};
  EXPECT_GT(footprint_leg_px(obtuse, &right), std::hypot(10.0, 3.0));
  EXPECT_EQ(right, 0);
}

TEST(FootprintLayout, CellsDoNotOverlapStayInsideAndPackTightly) {
  std::mt19937 rng(11);
  const auto& classes = footprint_leg_classes();
  for (int trial = 0; trial < 4; ++trial) {
    // Legs as an RTIN of a 640x480 frame has them: mostly small, some large; about half the triangles in diamonds
    // (pairs sharing their hypotenuse, here consecutive ones of the same leg).
    std::vector<FootprintTriangle> tris;
    std::discrete_distribution<int> pick({2, 3, 6, 8, 10, 10, 9, 7, 5, 4, 2, 1});
    const int n = trial == 0 ? 1 : 3000 * trial;
    for (int i = 0; i < n; ++i) {
      FootprintTriangle t;
      t.leg = classes[pick(rng)];
      if (i % 4 == 1) {  // a diamond with the previous one
        t.leg = tris.back().leg;
        t.diamond_partner = i - 1;
        t.swapped = i % 8 == 1;
        tris.back().diamond_partner = i;
      }
      tris.push_back(t);
    }
    FootprintLayout l;
    ASSERT_TRUE(make_footprint_layout(tris, 1, 8192, &l));
    EXPECT_EQ(l.width % 8, 0);
    EXPECT_EQ(l.height % 8, 0);
    std::vector<int> owner(static_cast<size_t>(l.width) * l.height, -1);
    size_t cells = 0, diamonds = 0;
    for (size_t t = 0; t < tris.size(); ++t) {
      const FootprintSlot& s = l.slots[t];
      ASSERT_EQ(s.diamond, tris[t].diamond_partner >= 0);
      ASSERT_EQ(s.cell_px, tris[t].leg + (s.diamond ? 2 : 4));
      ASSERT_GE(s.x0, 0);
      ASSERT_GE(s.y0, 0);
      ASSERT_LE(s.x0 + s.cell_px, l.width);
      ASSERT_LE(s.y0 + s.cell_px, l.height);
      // The corners sit inside the cell, the right angle first.
      const auto c = l.corners(t);
      const int leg = tris[t].leg + (s.lower && !s.diamond ? 1 : 0);
      EXPECT_NEAR((c[1] - c[0]).norm(), leg, 1e-12);
      EXPECT_NEAR((c[2] - c[0]).norm(), leg, 1e-12);
      EXPECT_NEAR((c[1] - c[0]).dot(c[2] - c[0]), 0.0, 1e-12);
      if (s.diamond && s.lower) {  // shares its hypotenuse with its partner's, vertex for vertex
        const auto p = l.corners(tris[t].diamond_partner);
        ++diamonds;
        EXPECT_EQ(c[1], s.swapped ? p[1] : p[2]);
        EXPECT_EQ(c[2], s.swapped ? p[2] : p[1]);
      }
      if (s.lower) continue;  // the cell is painted by its upper triangle
      ++cells;
      for (int y = s.y0; y < s.y0 + s.cell_px; ++y)
        for (int x = s.x0; x < s.x0 + s.cell_px; ++x) {
          int& o = owner[static_cast<size_t>(y) * l.width + x];
          ASSERT_EQ(o, -1) << "cells overlap at " << x << "," << y;
          o = static_cast<int>(t);
        }
    }
    EXPECT_EQ(diamonds, static_cast<size_t>(n / 4 + (n % 4 >= 2 ? 1 : 0)));
    EXPECT_EQ(cells, l.cells);
    // Pairs: every lower triangle shares its cell with an upper triangle of the same size class.
    size_t lower = 0;
    for (const auto& s : l.slots) lower += s.lower;
    EXPECT_EQ(lower + cells, tris.size());
    EXPECT_LE(l.cells, tris.size() / 2 + classes.size());
    // Packing: cells fill the atlas but for the shelves' ends; triangles' own area is what the gutters leave.
    const double cell_fill = l.cell_texels / (double(l.width) * l.height);
    std::printf("%zu triangles: atlas %dx%d, cells fill %.3f, triangle texels / atlas texels %.3f\n", tris.size(),
                l.width, l.height, cell_fill, l.efficiency());
    if (n > 1000) {
      EXPECT_GT(cell_fill, 0.9);
    }
    FootprintLayout again;
    ASSERT_TRUE(make_footprint_layout(tris, 1, 8192, &again));
    ASSERT_EQ(again.width, l.width);
    ASSERT_EQ(again.height, l.height);
    for (size_t t = 0; t < tris.size(); ++t) {
      ASSERT_EQ(again.slots[t].x0, l.slots[t].x0);
      ASSERT_EQ(again.slots[t].y0, l.slots[t].y0);
      ASSERT_EQ(again.slots[t].lower, l.slots[t].lower);
    }
  }
  FootprintLayout bad;
  auto legs = [](std::vector<int> l) {
    std::vector<FootprintTriangle> t(l.size());
    for (size_t i = 0; i < l.size(); ++i) t[i].leg = l[i];
    return t;
  };
  EXPECT_FALSE(make_footprint_layout(legs({4, 0}), 1, 8192, &bad));
  EXPECT_FALSE(make_footprint_layout(legs({4}), -1, 8192, &bad));
  EXPECT_FALSE(make_footprint_layout(legs(std::vector<int>(100000, 64)), 1, 1024, &bad));
  auto one_sided = legs({4, 4, 4});
  one_sided[0].diamond_partner = 1;  // 1 does not name 0 back
  EXPECT_FALSE(make_footprint_layout(one_sided, 1, 8192, &bad));
}

// Every texel a triangle owns maps back (M^-1, recovered from the output UVs as a viewer would) to the pixel where the
// surface point it shows projects: within 0.5 px (in fact to rounding). Bilinear lookups inside a triangle only read
// its own texels (the gutter). And the density is about one texel per source pixel along the legs.
TEST(FootprintAtlas, EveryTexelMapsBackToItsProjectionAndLookupsStayInTheirTriangle) {
  const CurvedScene sc = make_curved_scene();
  ASSERT_GT(sc.mesh.triangle_count(), 2000u);
  AtlasOptions o;
  o.mode = TextureMode::kFootprint;
  o.footprint_patch_deviation_px = 0;  // cells only (patches: FramePatchesKeepTheHalfPixelContractInFewerTexels)
  auto r = build_atlas(sc.mesh, sc.image, sc.k, o);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->mode, TextureMode::kFootprint);
  EXPECT_EQ(r->triangles, sc.mesh.triangle_count());
  EXPECT_EQ(r->mesh.positions.size(), 3 * r->triangles);
  const Eigen::Matrix3d K = sc.k.K();
  // Diamonds: triangles whose hypotenuse (v1, v2) sits on the same atlas corners.
  std::map<std::pair<std::pair<long, long>, std::pair<long, long>>, std::vector<size_t>> by_hypotenuse;
  for (size_t t = 0; t < r->triangles; ++t) {
    const auto c = corners_of(*r, t);
    std::pair<long, long> a(std::lround(c[1].x()), std::lround(c[1].y())),
        b(std::lround(c[2].x()), std::lround(c[2].y()));
    if (b < a) std::swap(a, b);
    by_hypotenuse[{a, b}].push_back(t);
  }
  std::vector<long> partner(r->triangles, -1);
  size_t diamonds = 0;
  for (const auto& [edge, ts] : by_hypotenuse)
    if (ts.size() == 2) {
      partner[ts[0]] = static_cast<long>(ts[1]);
      partner[ts[1]] = static_cast<long>(ts[0]);
      ++diamonds;
    }
  // Texel ownership: which triangle's texels each is (rebuilt from the UVs: cell = bounding square of the corners).
  std::vector<int> owner(r->texels, -1);
  double worst_px = 0, min_density = 1e9, max_density = 0;
  size_t texels_checked = 0;
  for (size_t t = 0; t < r->triangles; ++t) {
    const auto c = corners_of(*r, t);
    std::array<Eigen::Vector3d, 3> v;
    for (int i = 0; i < 3; ++i) v[i] = r->mesh.positions[r->mesh.indices[3 * t + i]].cast<double>();
    TriangleTextureMap map;
    ASSERT_TRUE(triangle_texture_map(v[0], v[1], v[2], K, c, &map));
    // The cell: upper triangles have their right angle at the top-left corner (+1, +1), lower ones at bottom-right;
    // S = leg + 4 for split cells (the lower leg is one more), leg + 2 for diamonds.
    const bool lower = c[0].x() > std::min(c[1].x(), c[2].x());
    const int leg = static_cast<int>(std::lround((c[1] - c[0]).norm()));
    const int S = partner[t] >= 0 ? leg + 2 : (lower ? leg + 3 : leg + 4);
    const int cx = static_cast<int>(std::lround(c[0].x())), cy = static_cast<int>(std::lround(c[0].y()));
    const int x0 = lower ? cx + 1 - S : cx - 1, y0 = lower ? cy + 1 - S : cy - 1;
    for (int j = 0; j < S; ++j)
      for (int i = 0; i < S; ++i) {
        if ((i + j + 1 < S) == lower) continue;
        int& o = owner[static_cast<size_t>(y0 + j) * r->width + x0 + i];
        o = static_cast<int>(t);
        const Eigen::Vector2d q(x0 + i + 0.5, y0 + j + 0.5);
        const Eigen::Vector3d bc = test::barycentric(q, c);
        if (bc.minCoeff() < 0) continue;  // gutter texels continue the plane; checked via the lookups below
        const Eigen::Vector3d X = bc[0] * v[0] + bc[1] * v[1] + bc[2] * v[2];
        const Eigen::Vector3d back = map.image_from_atlas * Eigen::Vector3d(q.x(), q.y(), 1);
        worst_px = std::max(worst_px, (sc.k.project(X) - back.head<2>() / back.z()).norm());
        ++texels_checked;
      }
    // Texels per source pixel along each leg (tiny triangles, legs under 8 px, are over-sampled by the whole-texel
    // classes and the lower triangle's extra texel: a 1.4 px leg gets 2 or 3 texels).
    for (int i : {1, 2}) {
      const double image_leg = (sc.k.project(v[i]) - sc.k.project(v[0])).norm();
      const double density = (c[i] - c[0]).norm() / image_leg;
      min_density = std::min(min_density, density);
      if (image_leg >= 8.0) max_density = std::max(max_density, density);
    }
  }
  std::printf(
      "%zu triangles (%zu diamonds), %zu texels inside them: worst texel -> image error %.2g px; texels per "
      "source pixel along the legs %.3f-%.3f (legs >= 8 px); atlas %dx%d, packing %.3f\n",
      r->triangles, diamonds, texels_checked, worst_px, min_density, max_density, r->width, r->height,
      r->packing_efficiency);
  EXPECT_GT(2 * diamonds, r->triangles / 4);  // a third of the triangles, on this mesh
  EXPECT_GT(texels_checked, 100000u);
  EXPECT_LT(worst_px, 0.5);
  EXPECT_LT(worst_px, 1e-6) << "exact up to rounding";
  EXPECT_GE(min_density, 1.0 - 1e-4);  // float vertices sit on pixel centres to ~1e-5 px
  EXPECT_LE(max_density, 1.2);         // RTIN legs hit a class; the lower triangle's leg is one texel more

  // Bilinear lookups at points inside each triangle read only that triangle's texels (or its diamond partner's, which
  // continue the same surface across their shared edge).
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> unit(0, 1);
  double foreign = 0;
  for (size_t t = 0; t < r->triangles; t += 7) {
    const auto c = corners_of(*r, t);
    for (int k = 0; k < 50; ++k) {
      double a = unit(rng), b = unit(rng);
      if (a + b > 1) a = 1 - a, b = 1 - b;
      const Eigen::Vector2d q = c[0] + a * (c[1] - c[0]) + b * (c[2] - c[0]);
      const double fx = q.x() - 0.5, fy = q.y() - 0.5;
      const int xa = int(std::floor(fx)), ya = int(std::floor(fy));
      const double wx = fx - xa, wy = fy - ya;
      const double w[4] = {(1 - wx) * (1 - wy), wx * (1 - wy), (1 - wx) * wy, wx * wy};
      for (int n = 0; n < 4; ++n) {
        const int x = xa + (n & 1), y = ya + (n >> 1);
        const int o =
            x >= 0 && y >= 0 && x < r->width && y < r->height ? owner[static_cast<size_t>(y) * r->width + x] : -1;
        const bool own = o == static_cast<int>(t) || (o >= 0 && o == partner[t]);
        if (!own) foreign = std::max(foreign, w[n]);
      }
    }
  }
  EXPECT_EQ(foreign, 0.0);
}

TEST(FootprintAtlas, SameInputGivesTheSameBytes) {
  const CurvedScene sc = make_curved_scene();
  AtlasOptions o;
  o.mode = TextureMode::kFootprint;
  auto a = build_atlas(sc.mesh, sc.image, sc.k, o), b = build_atlas(sc.mesh, sc.image, sc.k, o);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->mesh.texture.data, b->mesh.texture.data);
  EXPECT_EQ(a->mesh.texture_encoded, b->mesh.texture_encoded);
  EXPECT_EQ(a->mesh.indices, b->mesh.indices);
  ASSERT_EQ(a->mesh.uvs.size(), b->mesh.uvs.size());
  for (size_t i = 0; i < a->mesh.uvs.size(); ++i) {
    ASSERT_EQ(a->mesh.uvs[i], b->mesh.uvs[i]);
    ASSERT_EQ(a->mesh.positions[i], b->mesh.positions[i]);
  }
  // UVs sit on texel corners (cells) or centres (frame patches: vertices at pixel centres), so KHR_mesh_quantization
  // stores them exactly, and inside the atlas.
  for (const auto& uv : a->mesh.uvs) {
    const double x = 2 * uv.x() * a->width, y = 2 * uv.y() * a->height;
    ASSERT_NEAR(x, std::round(x), 2e-3);
    ASSERT_NEAR(y, std::round(y), 2e-3);
    ASSERT_GT(uv.x(), 0.0f);
    ASSERT_LT(uv.x(), 1.0f);
    ASSERT_GT(uv.y(), 0.0f);
    ASSERT_LT(uv.y(), 1.0f);
  }
}

TEST(FootprintAtlas, ModeNameAndBadOptions) {
  EXPECT_STREQ(to_string(TextureMode::kFootprint), "footprint");
  EXPECT_EQ(parse_texture_mode("footprint").value(), TextureMode::kFootprint);
  Intrinsics k;
  cv::Mat img(480, 640, CV_8UC3, cv::Scalar(10, 20, 30));
  Mesh m;
  m.positions = {{0, 0, 1}, {0.1f, 0, 1}, {0, 0.1f, 1}};
  m.indices = {0, 1, 2};
  AtlasOptions o;
  o.mode = TextureMode::kFootprint;
  auto patched = build_atlas(m, img, k, o);  // facing the camera: its frame mapping is exact, so a patch
  ASSERT_TRUE(patched.ok()) << patched.error().message;
  EXPECT_EQ(patched->patch_triangles, 1u);
  EXPECT_EQ(patched->cells, 0u);
  o.footprint_patch_deviation_px = 0;
  auto one = build_atlas(m, img, k, o);
  ASSERT_TRUE(one.ok()) << one.error().message;
  EXPECT_EQ(one->triangles, 1u);
  EXPECT_EQ(one->cells, 1u);
  for (double bad : {0.0, -1.0, 100.0, double(NAN)}) {
    o.texels_per_px = bad;
    EXPECT_EQ(build_atlas(m, img, k, o).error().code, ErrorCode::kInvalidArgument) << bad;
  }
  o = {};
  o.mode = TextureMode::kFootprint;
  o.footprint_patch_deviation_px = 0;
  o.gutter_px = 0;
  EXPECT_EQ(build_atlas(m, img, k, o).error().code, ErrorCode::kInvalidArgument);
  o.gutter_px = 1;
  o.max_atlas_side_px = 16;
  o.texels_per_px = 8;  // a 52-px triangle at 8 texels per pixel needs more than 16 texels
  EXPECT_EQ(build_atlas(m, img, k, o).error().code, ErrorCode::kInvalidArgument);
  Mesh behind = m;
  for (auto& p : behind.positions) p.z() = -1;
  o = {};
  o.mode = TextureMode::kFootprint;
  EXPECT_EQ(build_atlas(behind, img, k, o).error().code, ErrorCode::kEmpty);
}

// With patches: triangles whose frame mapping is within 0.25 px of the projective one are textured from 1:1 copies of
// the frame; every triangle, patch or cell, still shows within 0.5 px of where its surface points project, where a
// renderer looks (UVs interpolated linearly in the 3D barycentric coordinates), and the atlas gets smaller.
TEST(FootprintAtlas, FramePatchesKeepTheHalfPixelContractInFewerTexels) {
  const CurvedScene sc = make_curved_scene();
  AtlasOptions cells_only, patched;
  cells_only.mode = patched.mode = TextureMode::kFootprint;
  cells_only.footprint_patch_deviation_px = 0;  // patched: the default, 0.25 px
  auto a = build_atlas(sc.mesh, sc.image, sc.k, cells_only), b = build_atlas(sc.mesh, sc.image, sc.k, patched);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->patches, 0u);
  EXPECT_GT(b->patch_triangles, b->triangles / 4);
  EXPECT_LT(b->patch_triangles, b->triangles);  // the large oblique ones keep their cells
  EXPECT_EQ(b->triangles, a->triangles);
  // A patch's triangles share their vertices (one UV each there); cell triangles have their own.
  EXPECT_EQ(a->mesh.positions.size(), 3 * a->triangles);
  EXPECT_LT(b->mesh.positions.size(), 3 * (b->triangles - b->patch_triangles) + b->patch_triangles);
  double worst_patch = 0, worst_cell = 0;
  for (size_t t = 0; t < b->triangles; ++t) {
    const auto q = corners_of(*b, t);
    std::array<Eigen::Vector3d, 3> v;
    for (int i = 0; i < 3; ++i) v[i] = b->mesh.positions[b->mesh.indices[3 * t + i]].cast<double>();
    Eigen::Vector2d shift;
    const bool patch = test::is_patch_triangle(q, v, sc.k.K(), &shift);
    TriangleTextureMap map;
    if (!patch) {
      ASSERT_TRUE(triangle_texture_map(v[0], v[1], v[2], sc.k.K(), q, &map));
    }
    const int N = 12;
    for (int i = 0; i <= N; ++i)
      for (int j = 0; i + j <= N; ++j) {
        const double b1 = double(i) / N, b2 = double(j) / N, b0 = 1 - b1 - b2;
        const Eigen::Vector2d uv = b0 * q[0] + b1 * q[1] + b2 * q[2];
        const Eigen::Vector2d truth = sc.k.project(b0 * v[0] + b1 * v[1] + b2 * v[2]);
        if (patch) {
          worst_patch = std::max(worst_patch, (uv - shift - truth).norm());
        } else {
          const Eigen::Vector3d h = map.image_from_atlas * Eigen::Vector3d(uv.x(), uv.y(), 1);
          worst_cell = std::max(worst_cell, (h.head<2>() / h.z() - truth).norm());
        }
      }
  }
  std::printf(
      "%zu triangles: %zu in %zu frame patches (worst %.3f px), the rest in cells (worst %.2g px); atlas "
      "%dx%d (packing %.3f) vs %dx%d (%.3f) with cells only; JPEG q85 %zu vs %zu B\n",
      b->triangles, b->patch_triangles, b->patches, worst_patch, worst_cell, b->width, b->height, b->packing_efficiency,
      a->width, a->height, a->packing_efficiency, b->mesh.texture_encoded.size(), a->mesh.texture_encoded.size());
  EXPECT_LT(worst_patch, 0.5);
  EXPECT_LT(worst_cell, 1e-6);
  EXPECT_LT(b->texels, a->texels);
  // Still one texel per pixel or more, deterministic, and sampled texels untouched by the fill.
  auto again = build_atlas(sc.mesh, sc.image, sc.k, patched);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->mesh.texture_encoded, b->mesh.texture_encoded);
}
