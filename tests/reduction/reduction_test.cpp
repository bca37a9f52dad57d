#include <gtest/gtest.h>

#include <set>
#include <tuple>

#include "input/frame_source.h"
#include "reduction/pipeline.h"
#include "reduction/stages.h"
#include "tests/common/test_data.h"

namespace rgbdcast {
namespace {

const StageReport* stage(const ReducedFrame& r, const std::string& name) {
  for (const auto& s : r.stages)
    if (s.name == name) return &s;
  return nullptr;
}

double max_perimeter(const Mesh& m) {
  double worst = 0;
  for (size_t t = 0; t < m.indices.size(); t += 3) {
    const auto& a = m.positions[m.indices[t]];
    const auto& b = m.positions[m.indices[t + 1]];
    const auto& c = m.positions[m.indices[t + 2]];
    worst = std::max<double>(worst, (b - a).norm() + (c - b).norm() + (a - c).norm());
  }
  return worst;
}

class Fr1XyzFrame : public ::testing::TestWithParam<int> {};

// The paper's pipeline on the real TUM fr1/xyz frames it was evaluated on.
TEST_P(Fr1XyzFrame, ReducesLikeThePaper) {
  REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz");
  SourceOptions o;
  o.intrinsics = "fr1";
  auto src = open_frame_source(test::data_path("tum/rgbd_dataset_freiburg1_xyz"), o);
  ASSERT_TRUE(src) << src.error().message;
  auto frame = (*src)->frame(GetParam());
  ASSERT_TRUE(frame) << frame.error().message;
  ReductionParams params;
  auto r = reduce_frame(*frame, params);
  ASSERT_TRUE(r) << r.error().message;

  std::vector<std::string> names;
  for (const auto& s : r->stages) names.push_back(s.name);
  EXPECT_EQ(names, (std::vector<std::string>{"valid", "outliers", "voxel", "triangulate", "perimeter"}));

  // valid = every pixel with depth: 307,200 minus the zero-depth pixels, about 75 %.
  const size_t nonzero = static_cast<size_t>(cv::countNonZero(frame->depth_m));
  EXPECT_EQ(stage(*r, "valid")->count, nonzero);
  EXPECT_GT(nonzero, 0.70 * 307200);
  EXPECT_LT(nonzero, 0.80 * 307200);
  // Outlier removal removes some but not most points.
  EXPECT_LT(stage(*r, "outliers")->count, nonzero);
  EXPECT_GT(stage(*r, "outliers")->count, 0.8 * nonzero);
  // Voxel grid 1 cm: the paper reports ~22,500 points.
  EXPECT_GE(stage(*r, "voxel")->count, 10000u);
  EXPECT_LE(stage(*r, "voxel")->count, 40000u);
  EXPECT_EQ(r->cloud.size(), stage(*r, "voxel")->count);
  // Triangles: the paper reports ~40,000.
  EXPECT_GT(r->mesh.triangle_count(), 10000u);
  EXPECT_EQ(stage(*r, "perimeter")->count, r->mesh.triangle_count());
  EXPECT_LE(max_perimeter(r->mesh), 3 * params.max_edge_m + 1e-6);
  // Every triangle faces the camera (counter-clockwise seen from it).
  size_t facing = 0;
  for (size_t t = 0; t < r->mesh.indices.size(); t += 3) {
    const auto& a = r->mesh.positions[r->mesh.indices[t]];
    const auto& b = r->mesh.positions[r->mesh.indices[t + 1]];
    const auto& c = r->mesh.positions[r->mesh.indices[t + 2]];
    facing += (b - a).cross(c - a).dot(a) <= 0.f;
  }
  EXPECT_EQ(facing, r->mesh.triangle_count());
  EXPECT_EQ(r->mesh.colors.size(), r->mesh.positions.size());
  for (const auto& s : r->stages) EXPECT_GE(s.ms, 0.0);
}

INSTANTIATE_TEST_SUITE_P(AllThreeFrames, Fr1XyzFrame, ::testing::Values(0, 1, 2));

TEST(Reduction, PerimeterFilterDropsLongTriangles) {
  // Three points of a 1 m triangle and three of a 1 cm one: with d = 5 cm only the small one survives.
  Cloud cloud;
  for (auto [x, y] :
       std::vector<std::pair<float, float>>{{0, 0}, {1, 0}, {0, 1}, {0, 0.5f}, {0.01f, 0.5f}, {0, 0.51f}}) {
    CloudPoint p;
    p.x = x;
    p.y = y;
    p.z = 1;
    cloud.push_back(p);
  }
  auto kept = filter_by_perimeter(cloud, {0, 1, 2, 3, 4, 5}, 3 * 0.05);
  EXPECT_EQ(kept, (std::vector<std::uint32_t>{3, 4, 5}));
}

TEST(Reduction, RejectsBadParameters) {
  RgbdFrame f;
  f.color_rgb = cv::Mat(4, 4, CV_8UC3, cv::Scalar(1, 2, 3));
  f.depth_m = cv::Mat(4, 4, CV_32F, cv::Scalar(1.0f));
  for (double v : {0.0, -0.01, std::nan("")}) {
    ReductionParams p;
    p.voxel_size_m = v;
    auto r = reduce_frame(f, p);
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().code, ErrorCode::kInvalidArgument);
    EXPECT_NE(r.error().message.find("voxel"), std::string::npos);
  }
}

TEST(Reduction, AllZeroDepthIsEmpty) {
  RgbdFrame f;
  f.color_rgb = cv::Mat(48, 64, CV_8UC3, cv::Scalar(1, 2, 3));
  f.depth_m = cv::Mat(48, 64, CV_32F, cv::Scalar(0.0f));
  auto r = reduce_frame(f, {});
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, ErrorCode::kEmpty);
}

}  // namespace
}  // namespace rgbdcast

namespace rgbdcast {
namespace {

// Beyond the paper: error-bounded simplification keeps the outline and the vertices (a subset of the voxel
// cloud) and removes most interior triangles of the desk's flat surfaces.
TEST(Reduction, SimplifyHalvesTheTrianglesOnRealData) {
  REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz");
  SourceOptions o;
  o.intrinsics = "fr1";
  auto src = open_frame_source(test::data_path("tum/rgbd_dataset_freiburg1_xyz"), o);
  ASSERT_TRUE(src);
  auto frame = (*src)->frame(0);
  ASSERT_TRUE(frame);
  ReductionParams paper, simplified;
  simplified.simplify_error_m = 0.004;
  auto a = reduce_frame(*frame, paper);
  auto b = reduce_frame(*frame, simplified);
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->stages.size(), 5u);  // off by default: the paper's pipeline
  ASSERT_EQ(b->stages.size(), 6u);
  EXPECT_EQ(b->stages.back().name, "simplify");
  EXPECT_LT(b->mesh.triangle_count(), a->mesh.triangle_count() / 2);
  EXPECT_GT(b->mesh.triangle_count(), 1000u);
  // Every kept vertex is one of the reduction's own points: nothing is invented.
  std::set<std::tuple<float, float, float>> original;
  for (const auto& p : a->mesh.positions) original.insert({p.x(), p.y(), p.z()});
  for (const auto& p : b->mesh.positions) EXPECT_TRUE(original.count({p.x(), p.y(), p.z()}));
  const double grown = max_perimeter(b->mesh);
  RecordProperty("max_perimeter_after_simplify_m", std::to_string(grown));
  std::printf("max triangle perimeter: %.3f m before, %.3f m after simplification (3d = %.3f m)\n",
              max_perimeter(a->mesh), grown, 3 * paper.max_edge_m);
}

}  // namespace
}  // namespace rgbdcast
