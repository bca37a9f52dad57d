// The realtime preset's depth filter and RTIN triangulation (reduction/depth_filter.h, reduction/depth_mesh.h) on
// synthetic depth with known answers, and on the shared real frames.
#include <gtest/gtest.h>

#include <cstring>
#include <map>
#include <iostream>
#include <set>
#include <tuple>

#include "input/frame_source.h"
#include "reduction/depth_filter.h"
#include "reduction/depth_mesh.h"
#include "reduction/mesh_edges.h"
#include "reduction/pipeline.h"
#include "tests/common/test_data.h"

namespace rgbdcast {
namespace {

Intrinsics kinect() { return Intrinsics{}; }

Result<RgbdFrame> fr1_frame(size_t i) {
  SourceOptions o;
  o.intrinsics = "fr1";
  auto src = open_frame_source(test::data_path("tum/rgbd_dataset_freiburg1_xyz"), o);
  if (!src) return src.error();
  return (*src)->frame(i);
}

// Depth of the plane n . X = d seen by the camera: z = d / (n . K^-1 (u, v, 1)).
cv::Mat plane_depth(const Intrinsics& k, const Eigen::Vector3d& n, double d) {
  cv::Mat z(k.height, k.width, CV_32FC1);
  for (int v = 0; v < k.height; ++v)
    for (int u = 0; u < k.width; ++u) {
      const Eigen::Vector3d ray((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
      z.at<float>(v, u) = static_cast<float>(d / n.dot(ray));
    }
  return z;
}

struct Built {
  Mesh mesh;
  std::vector<Eigen::Vector2i> pixels;
  DepthFilterResult filtered;
};

Built build(const cv::Mat& depth, const Intrinsics& k, double tol = 2.0, DepthMeshParams p = {}) {
  auto f = filter_depth(depth, DepthFilterParams{});
  EXPECT_TRUE(f) << f.error().message;
  auto h = DepthMeshHierarchy::build(f->depth_m, f->vertex_depth_m, k, p);
  EXPECT_TRUE(h) << h.error().message;
  Built b;
  b.mesh = h->extract(tol, &b.pixels);
  b.filtered = std::move(*f);
  return b;
}

// Every edge of the mesh (grid pixels) with the number of triangles using it.
std::map<std::pair<int, int>, int> edge_uses(const Mesh& m) {
  std::map<std::pair<int, int>, int> uses;
  for (size_t t = 0; t < m.indices.size(); t += 3)
    for (int e = 0; e < 3; ++e) {
      const int a = static_cast<int>(m.indices[t + e]), b = static_cast<int>(m.indices[t + (e + 1) % 3]);
      ++uses[{std::min(a, b), std::max(a, b)}];
    }
  return uses;
}

// Grid points lying strictly inside an edge that are vertices of the mesh: T-junctions.
size_t t_junctions(const Mesh& m, const std::vector<Eigen::Vector2i>& px) {
  std::set<std::pair<int, int>> vertices;
  for (const auto& p : px) vertices.insert({p.x(), p.y()});
  size_t found = 0;
  for (const auto& [edge, uses] : edge_uses(m)) {
    const Eigen::Vector2i a = px[edge.first], b = px[edge.second];
    const Eigen::Vector2i d = b - a;
    const int steps = std::max(std::abs(d.x()), std::abs(d.y()));
    const Eigen::Vector2i step = d / steps;  // RTIN edges are axis-aligned or diagonal
    for (int s = 1; s < steps; ++s) {
      const Eigen::Vector2i q = a + s * step;
      if (vertices.count({q.x(), q.y()})) ++found;
    }
  }
  return found;
}

TEST(DepthMesh, PlaneGivesFewTrianglesAndZeroError) {
  const Intrinsics k = kinect();
  const Eigen::Vector3d n = Eigen::Vector3d(0.2, -0.5, 1.0).normalized();
  const cv::Mat depth = plane_depth(k, n, 1.5);
  DepthMeshParams geometry_only;
  geometry_only.texture_deviation_px = 0;  // a tilted plane's large triangles would split for the frame texture
  Built b = build(depth, k, 2.0, geometry_only);
  ASSERT_FALSE(b.mesh.indices.empty());
  // 80 tiles of 64 px would be 160 triangles; the last tile row runs 32 px past the image and splits once more.
  EXPECT_LE(b.mesh.triangle_count(), 400u);
  EXPECT_EQ(b.filtered.kept, static_cast<size_t>(k.width * k.height));
  double worst_m = 0;
  for (const auto& p : b.mesh.positions) worst_m = std::max(worst_m, std::abs(n.dot(p.cast<double>()) - 1.5));
  EXPECT_LT(worst_m, 1e-5);
  EXPECT_EQ(t_junctions(b.mesh, b.pixels), 0u);
}

TEST(DepthMesh, StepEdgeLeavesNoTriangleAcrossTheJump) {
  const Intrinsics k = kinect();
  cv::Mat depth(k.height, k.width, CV_32FC1, cv::Scalar(2.0f));
  depth(cv::Rect(0, 0, 300, k.height)).setTo(1.0f);
  depth(cv::Rect(200, 100, 200, 150)).setTo(1.2f);  // a box in front of the wall, straddling the step
  Built b = build(depth, k);
  ASSERT_GT(b.mesh.triangle_count(), 0u);
  size_t across = 0;
  for (size_t t = 0; t < b.mesh.indices.size(); t += 3) {
    float lo = 1e9f, hi = 0;
    for (int i = 0; i < 3; ++i) {
      const float z = b.mesh.positions[b.mesh.indices[t + i]].z();
      lo = std::min(lo, z), hi = std::max(hi, z);
    }
    if (hi > lo * 1.01f) ++across;
  }
  EXPECT_EQ(across, 0u);
  // Large triangles on the flat parts, small ones only along the edges (x = 300, and the box's outline).
  auto near_edge = [](const Eigen::Vector2i& p) {
    const bool box_x = p.x() >= 197 && p.x() <= 402, box_y = p.y() >= 97 && p.y() <= 252;
    return std::abs(p.x() - 300) <= 3 || (box_y && (std::abs(p.x() - 200) <= 3 || std::abs(p.x() - 399) <= 3)) ||
           (box_x && (std::abs(p.y() - 100) <= 3 || std::abs(p.y() - 249) <= 3));
  };
  size_t large = 0, small_far = 0;
  for (size_t t = 0; t < b.mesh.indices.size(); t += 3) {
    const Eigen::Vector2i a = b.pixels[b.mesh.indices[t]], bb = b.pixels[b.mesh.indices[t + 1]],
                          c = b.pixels[b.mesh.indices[t + 2]];
    const int area2 = std::abs((bb - a).x() * (c - a).y() - (bb - a).y() * (c - a).x());
    if (area2 >= 2 * 512) ++large;
    if (area2 < 2 * 8 && !near_edge(a) && !near_edge(bb) && !near_edge(c)) ++small_far;
  }
  EXPECT_GT(large, 100u);
  EXPECT_LT(small_far, b.mesh.triangle_count() / 10);
  EXPECT_EQ(t_junctions(b.mesh, b.pixels), 0u);
}

TEST(DepthMesh, CrackFreeOnARealFrame) {
  REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz");
  auto frame = fr1_frame(0);
  ASSERT_TRUE(frame) << frame.error().message;
  Built b = build(frame->depth_m, frame->intrinsics.pinhole());
  ASSERT_GT(b.mesh.triangle_count(), 1000u);
  EXPECT_EQ(t_junctions(b.mesh, b.pixels), 0u);
  // Every edge has one triangle (the boundary) or two (interior); a boundary edge borders a dropped pixel or the
  // image's edge.
  size_t boundary = 0, interior = 0, over = 0;
  for (const auto& [edge, uses] : edge_uses(b.mesh)) {
    if (uses == 1)
      ++boundary;
    else if (uses == 2)
      ++interior;
    else
      ++over;
  }
  EXPECT_EQ(over, 0u);
  EXPECT_GT(interior, boundary);
  // Every triangle faces the camera (counter-clockwise seen from it).
  size_t back = 0;
  for (size_t t = 0; t < b.mesh.indices.size(); t += 3) {
    const Eigen::Vector3f a = b.mesh.positions[b.mesh.indices[t]], bb = b.mesh.positions[b.mesh.indices[t + 1]],
                          c = b.mesh.positions[b.mesh.indices[t + 2]];
    if ((bb - a).cross(c - a).dot(a) >= 0) ++back;
  }
  EXPECT_EQ(back, 0u);
}

TEST(DepthMesh, DeterministicByteForByte) {
  REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz");
  auto frame = fr1_frame(1);
  ASSERT_TRUE(frame) << frame.error().message;
  ReductionParams p = reduction_preset(Preset::kRealtime);
  auto a = reduce_frame(*frame, p);
  auto b = reduce_frame(*frame, p);
  ASSERT_TRUE(a && b);
  ASSERT_EQ(a->mesh.positions.size(), b->mesh.positions.size());
  ASSERT_EQ(a->mesh.indices, b->mesh.indices);
  EXPECT_EQ(std::memcmp(a->mesh.positions.data(), b->mesh.positions.data(),
                        a->mesh.positions.size() * sizeof(Eigen::Vector3f)),
            0);
}

// The realtime stage after the hierarchy: edge collapses in (u, v, w / sigma) space straighten the one-pixel
// staircases along outlines. On a real frame the mesh keeps being a manifold facing the camera, loses most of its
// triangles, and keeps its outline: no vertex leaves the surface (every vertex is one of the hierarchy's).
TEST(DepthMesh, SimplificationStraightensOutlinesAndKeepsTheSurface) {
  REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz");
  auto frame = fr1_frame(0);
  ASSERT_TRUE(frame) << frame.error().message;
  ReductionParams p = reduction_preset(Preset::kRealtime);
  p.depth_mesh.tolerance_factor = 8;
  ReductionParams off = p;
  off.depth_mesh.simplify_px = 0;
  auto a = reduce_frame(*frame, off);
  auto b = reduce_frame(*frame, p);
  ASSERT_TRUE(a && b);
  std::cout << "fr1/xyz frame 0 at 8 sigma: " << a->mesh.triangle_count() << " triangles, " << b->mesh.triangle_count()
            << " after collapses\n";
  EXPECT_LT(b->mesh.triangle_count(), a->mesh.triangle_count() * 3 / 4);
  std::set<std::tuple<float, float, float>> hierarchy_vertices;
  for (const auto& v : a->mesh.positions) hierarchy_vertices.insert({v.x(), v.y(), v.z()});
  size_t foreign = 0;
  for (const auto& v : b->mesh.positions) foreign += !hierarchy_vertices.count({v.x(), v.y(), v.z()});
  EXPECT_EQ(foreign, 0u);
  size_t over = 0, back = 0;
  for (const auto& [edge, uses] : edge_uses(b->mesh)) over += uses > 2;
  for (size_t t = 0; t < b->mesh.indices.size(); t += 3) {
    const Eigen::Vector3f v0 = b->mesh.positions[b->mesh.indices[t]], v1 = b->mesh.positions[b->mesh.indices[t + 1]],
                          v2 = b->mesh.positions[b->mesh.indices[t + 2]];
    if ((v1 - v0).cross(v2 - v0).dot(v0) >= 0) ++back;
  }
  EXPECT_EQ(over, 0u);
  EXPECT_EQ(back, 0u);
}

// A collapse never joins the two sides of a depth step: they share no edge, and the step stays open.
TEST(DepthMesh, SimplificationLeavesNoTriangleAcrossAStep) {
  const Intrinsics k = kinect();
  RgbdFrame frame;
  frame.intrinsics = k;
  frame.depth_m = cv::Mat(k.height, k.width, CV_32FC1, cv::Scalar(2.0f));
  frame.depth_m(cv::Rect(0, 0, 300, k.height)).setTo(1.0f);
  frame.depth_m(cv::Rect(200, 100, 200, 150)).setTo(1.2f);
  frame.color_rgb = cv::Mat(k.height, k.width, CV_8UC3, cv::Scalar(90, 120, 150));
  auto r = reduce_frame(frame, reduction_preset(Preset::kRealtime));
  ASSERT_TRUE(r) << r.error().message;
  size_t across = 0;
  for (size_t t = 0; t < r->mesh.indices.size(); t += 3) {
    float lo = 1e9f, hi = 0;
    for (int i = 0; i < 3; ++i) {
      const float z = r->mesh.positions[r->mesh.indices[t + i]].z();
      lo = std::min(lo, z), hi = std::max(hi, z);
    }
    if (hi > lo * 1.01f) ++across;
  }
  EXPECT_GT(r->mesh.triangle_count(), 0u);
  EXPECT_EQ(across, 0u);
}

TEST(DepthMesh, FilterDropsFlyingPixelsAndSpeckles) {
  const Intrinsics k = kinect();
  cv::Mat depth(k.height, k.width, CV_32FC1, cv::Scalar(2.0f));
  depth(cv::Rect(0, 0, 320, k.height)).setTo(1.0f);
  // Flying pixels on the edge: halfway between the two surfaces, one pixel wide.
  for (int v = 0; v < k.height; v += 2) depth.at<float>(v, 320) = 1.5f;
  // A speckle: a 3x3 island far in front of the wall.
  depth(cv::Rect(500, 200, 3, 3)).setTo(0.6f);
  auto f = filter_depth(depth, DepthFilterParams{});
  ASSERT_TRUE(f) << f.error().message;
  EXPECT_EQ(f->valid, static_cast<size_t>(k.width * k.height));
  EXPECT_GE(f->flying + f->speckles, static_cast<size_t>(k.height / 2 + 9));
  // The flying pixels lie between two surfaces: dropped, and their gap is not filled.
  for (int v = 0; v < k.height; v += 2) EXPECT_EQ(f->depth_m.at<float>(v, 320), 0.f) << "row " << v;
  // The speckle is dropped, and its gap inside the wall takes the wall's depth.
  EXPECT_FLOAT_EQ(f->depth_m.at<float>(201, 501), 2.0f);
  EXPECT_GE(f->filled, 9u);
  EXPECT_EQ(f->depth_m.at<float>(100, 100), 1.0f);
  EXPECT_EQ(f->depth_m.at<float>(100, 600), 2.0f);
}

// The per-pixel passes on row bands, the counts on tiles: two threads give what one gives, bit for bit.
TEST(DepthMesh, FilterAndCountsAreTheSameOnTwoThreads) {
  REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz");
  auto frame = fr1_frame(0);
  ASSERT_TRUE(frame) << frame.error().message;
  auto one = filter_depth(frame->depth_m, DepthFilterParams{}, 1);
  auto two = filter_depth(frame->depth_m, DepthFilterParams{}, 2);
  ASSERT_TRUE(one && two);
  EXPECT_EQ(one->flying, two->flying);
  EXPECT_EQ(one->filled, two->filled);
  EXPECT_GT(one->filled, 0u);
  EXPECT_EQ(cv::norm(one->depth_m, two->depth_m, cv::NORM_INF), 0.0);
  auto h =
      DepthMeshHierarchy::build(one->depth_m, one->vertex_depth_m, frame->intrinsics.pinhole(), DepthMeshParams{}, 1);
  ASSERT_TRUE(h) << h.error().message;
  const auto c1 = h->counts(2.0, 1), c2 = h->counts(2.0, 2);
  for (double t : {2.0, 3.0, 5.5, 8.0, 16.0, 32.0}) EXPECT_EQ(c1.at(t), c2.at(t)) << t;
  EXPECT_EQ(c1.at(2.0), h->extract(2.0).triangle_count());  // the minimum is exact
}

// The gap fill, read window by window as its rule says: an invalid pixel (no kept depth) whose (2R + 1)^2 window holds
// kept depth on at least a quarter of its pixels, all within twice the jump of each other, takes their mean; no
// other pixel changes. The filter's separable tests must pick the same pixels, and the fills must be the window's
// float sum in row-major order over the count, bit for bit (what the fill has always computed: the realtime
// goldens depend on it), on real frames of two cameras.
TEST(DepthMesh, GapFillIsTheWindowMeanOfOneSurface) {
  REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz");
  REQUIRE_DATA("augmented_icl_livingroom");
  std::vector<cv::Mat> depths;
  for (size_t i : {0, 1}) {
    auto frame = fr1_frame(i);
    ASSERT_TRUE(frame) << frame.error().message;
    depths.push_back(frame->depth_m);
  }
  {
    auto src = open_frame_source(test::data_path("augmented_icl_livingroom"), SourceOptions{});
    ASSERT_TRUE(src) << src.error().message;
    auto frame = (*src)->frame(0);
    ASSERT_TRUE(frame) << frame.error().message;
    depths.push_back(frame->depth_m);
  }
  for (size_t d = 0; d < depths.size(); ++d) {
    DepthFilterParams unfilled;
    unfilled.gap_fill_px = 0;
    auto kept = filter_depth(depths[d], unfilled, 2);
    auto f = filter_depth(depths[d], DepthFilterParams{}, 2);
    ASSERT_TRUE(kept && f);
    const int R = DepthFilterParams{}.gap_fill_px, w = depths[d].cols, h = depths[d].rows;
    const double max_ratio = 1 + 2 * DepthFilterParams{}.jump_relative;
    size_t expected = 0, worst_mismatch = 0;
    double worst_relative = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const float own = kept->depth_m.at<float>(y, x);
        const float got = f->depth_m.at<float>(y, x);
        if (own > 0.f) {
          ASSERT_EQ(got, own) << "a kept pixel changed at " << x << "," << y;
          continue;
        }
        float sum = 0;
        double far = 0, near = 1e30;
        int count = 0;
        for (int yy = std::max(0, y - R); yy <= std::min(h - 1, y + R); ++yy)
          for (int xx = std::max(0, x - R); xx <= std::min(w - 1, x + R); ++xx) {
            const float z = kept->depth_m.at<float>(yy, xx);
            if (z <= 0) continue;
            sum += z, ++count, far = std::max<double>(far, z), near = std::min<double>(near, z);
          }
        const bool fill = count >= 0.25 * (2 * R + 1) * (2 * R + 1) && far <= near * max_ratio;
        if (!fill) {
          if (got != 0.f) ++worst_mismatch;
          continue;
        }
        ++expected;
        if (got <= 0.f) {
          ++worst_mismatch;
          continue;
        }
        const float mean = sum / static_cast<float>(count);
        if (got != mean) worst_relative = std::max(worst_relative, std::abs(double(got) - mean) / mean);
      }
    EXPECT_GT(expected, 500u) << "frame " << d;
    EXPECT_EQ(f->filled, expected) << "frame " << d;
    EXPECT_EQ(worst_mismatch, 0u) << "frame " << d;
    EXPECT_EQ(worst_relative, 0.0) << "frame " << d << ": a fill is not the window's mean";
  }
}

// A hierarchy built with a layout made beforehand (as prepare_realtime makes it, beside the filter) is the one built
// without; a layout for another image size or other parameters is not used, and the result is the same again.
TEST(DepthMesh, AGivenLayoutGivesTheSameMeshAndAForeignOneIsIgnored) {
  REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz");
  auto frame = fr1_frame(0);
  ASSERT_TRUE(frame) << frame.error().message;
  auto f = filter_depth(frame->depth_m, DepthFilterParams{}, 2, [] {});
  ASSERT_TRUE(f) << f.error().message;
  const Intrinsics k = frame->intrinsics.pinhole();
  const DepthMeshParams p;
  DepthMeshParams other = p;
  other.jump_relative = 0.05;
  auto mesh_with = [&](std::shared_ptr<const DepthMeshLayout> layout) {
    auto h = DepthMeshHierarchy::build(f->depth_m, f->vertex_depth_m, k, p, 2, std::move(layout));
    EXPECT_TRUE(h) << h.error().message;
    return h ? h->extract(2.0) : Mesh{};
  };
  const Mesh plain = mesh_with(nullptr);
  ASSERT_GT(plain.triangle_count(), 1000u);
  for (auto layout : {make_depth_mesh_layout(f->depth_m.cols, f->depth_m.rows, p),
                      make_depth_mesh_layout(f->depth_m.cols / 2, f->depth_m.rows, p),
                      make_depth_mesh_layout(f->depth_m.cols, f->depth_m.rows, other)}) {
    const Mesh m = mesh_with(layout);
    EXPECT_EQ(m.indices, plain.indices);
    ASSERT_EQ(m.positions.size(), plain.positions.size());
    EXPECT_EQ(std::memcmp(m.positions.data(), plain.positions.data(), m.positions.size() * sizeof(Eigen::Vector3f)), 0);
  }
  // The foreign parameters' own layout does matter: with it (and them) the mesh differs.
  auto h = DepthMeshHierarchy::build(f->depth_m, f->vertex_depth_m, k, other, 2,
                                     make_depth_mesh_layout(f->depth_m.cols, f->depth_m.rows, other));
  ASSERT_TRUE(h) << h.error().message;
  EXPECT_NE(h->extract(2.0).indices, plain.indices);
}

// The budget walks the counts from 8 sigma first and from its minimum only when it needs a lower tolerance
// (pipeline/frame_scene.cpp): above a walk's minimum its counts must be those of a walk from lower down.
TEST(DepthMesh, CountsAboveAWalksMinimumAreThoseOfAWalkFromBelow) {
  REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz");
  auto frame = fr1_frame(0);
  ASSERT_TRUE(frame) << frame.error().message;
  auto f = filter_depth(frame->depth_m, DepthFilterParams{}, 2);
  ASSERT_TRUE(f) << f.error().message;
  auto h = DepthMeshHierarchy::build(f->depth_m, f->vertex_depth_m, frame->intrinsics.pinhole(), DepthMeshParams{}, 2);
  ASSERT_TRUE(h) << h.error().message;
  const auto low = h->counts(2.0, 2), high = h->counts(8.0, 2);
  EXPECT_EQ(high.minimum(), 8.0);
  // (At its minimum a walk's count is exact; elsewhere either gives its bin's top, so 8.0 itself is compared with
  // the mesh.)
  for (double t : {8.01, 8.05, 9.5, 12.0, 16.0, 24.0, 31.9, 32.0, 40.0}) EXPECT_EQ(low.at(t), high.at(t)) << t;
  EXPECT_EQ(high.at(8.0), h->extract(8.0).triangle_count());
  EXPECT_EQ(low.at(2.0), h->extract(2.0).triangle_count());
  for (double want : {0.5, 0.9, 0.99})  // fractions of the count at 8 sigma: answers above the minimum
    EXPECT_EQ(low.smallest_with_at_most(want * high.at(8.0), 32), high.smallest_with_at_most(want * high.at(8.0), 32));
  // At or under the count at the minimum the answer may lie below it: the partial walk answers its minimum.
  EXPECT_EQ(high.smallest_with_at_most(1.5 * high.at(8.0), 32), 8.0);
  EXPECT_LT(low.smallest_with_at_most(1.5 * high.at(8.0), 32), 8.0);
}

// Edge use counts (linear, by lower vertex) agree with a map of every edge, on a real mesh and on a fold.
TEST(DepthMesh, EdgeUseCountsMatchAMapOfEdges) {
  REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz");
  auto frame = fr1_frame(0);
  ASSERT_TRUE(frame) << frame.error().message;
  Built b = build(frame->depth_m, frame->intrinsics.pinhole());
  const auto uses = edge_use_counts(b.mesh.indices, b.mesh.positions.size());
  const auto by_map = edge_uses(b.mesh);
  ASSERT_EQ(uses.size(), b.mesh.indices.size());
  size_t boundary = 0;
  for (size_t s = 0; s < uses.size(); ++s) {
    const int a = static_cast<int>(b.mesh.indices[s]);
    const int c = static_cast<int>(b.mesh.indices[s - s % 3 + (s % 3 + 1) % 3]);
    EXPECT_EQ(uses[s], static_cast<std::uint32_t>(by_map.at({std::min(a, c), std::max(a, c)}))) << s;
    boundary += uses[s] == 1;
  }
  EXPECT_GT(boundary, 0u);
  // Three triangles on edge 0-1 (a fold), the rest on one each.
  const std::vector<std::uint32_t> fold = {0, 1, 2, 1, 0, 3, 0, 1, 4};
  EXPECT_EQ(edge_use_counts(fold, 5), (std::vector<std::uint32_t>{3, 1, 1, 3, 1, 1, 3, 1, 1}));
}

// The budget extracts with no collapses and collapses next (pipeline/frame_scene.cpp): the extraction's edge counts
// must reach the collapses as the counts of the extracted mesh, and be gone once the collapses change the mesh.
TEST(DepthMesh, TheExtractionsEdgeCountsReachTheCollapsesAndGoWithThem) {
  REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz");
  auto frame = fr1_frame(1);
  ASSERT_TRUE(frame) << frame.error().message;
  const ReductionParams params = reduction_preset(Preset::kRealtime);
  auto prepared = prepare_realtime(*frame, params);
  ASSERT_TRUE(prepared) << prepared.error().message;
  auto reduced = extract_realtime(*prepared, *frame, 32.0, 0);
  ASSERT_TRUE(reduced) << reduced.error().message;
  ASSERT_GT(reduced->mesh.triangle_count(), 1000u);
  EXPECT_EQ(reduced->edge_uses, edge_use_counts(reduced->mesh.indices, reduced->mesh.positions.size()));
  // The collapses with those counts give the mesh they give without them.
  const size_t extracted = reduced->mesh.triangle_count();
  ReducedFrame without = *reduced;
  without.edge_uses.clear();
  ASSERT_TRUE(simplify_realtime(*prepared, *frame, 2.0, &*reduced));
  ASSERT_TRUE(simplify_realtime(*prepared, *frame, 2.0, &without));
  EXPECT_LT(reduced->mesh.triangle_count(), extracted);
  EXPECT_EQ(reduced->mesh.indices, without.mesh.indices);
  EXPECT_TRUE(reduced->edge_uses.empty());
  // With the collapses in the one call, nothing is left either.
  auto collapsed = extract_realtime(*prepared, *frame, 32.0, 2.0);
  ASSERT_TRUE(collapsed) << collapsed.error().message;
  EXPECT_TRUE(collapsed->edge_uses.empty());
  EXPECT_EQ(collapsed->mesh.indices, reduced->mesh.indices);
}

TEST(DepthMesh, RejectsAbsurdParameters) {
  DepthMeshParams p;
  p.tile_px = 48;
  EXPECT_FALSE(p.validate());
  p = {};
  p.noise_m_per_m2 = -1;
  EXPECT_FALSE(p.validate());
  p = {};
  p.tolerance_factor = std::nan("");
  EXPECT_FALSE(p.validate());
  cv::Mat empty;
  EXPECT_FALSE(filter_depth(empty, DepthFilterParams{}));
}

}  // namespace
}  // namespace rgbdcast
