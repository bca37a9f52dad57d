#include <gtest/gtest.h>

#include <fstream>
#include <random>

#include "input/intrinsics_io.h"
#include "tests/common/test_data.h"

namespace rgbdcast {
namespace {

TEST(Intrinsics, PresetsMatchTheTumCalibration) {
  auto fr1 = intrinsics_preset("fr1");
  ASSERT_TRUE(fr1);
  EXPECT_DOUBLE_EQ(fr1->fx, 517.3);
  EXPECT_DOUBLE_EQ(fr1->cy, 255.3);
  EXPECT_TRUE(fr1->has_distortion());
  EXPECT_DOUBLE_EQ(fr1->distortion[4], 1.1633);
  EXPECT_DOUBLE_EQ(fr1->depth_scale, 5000.0);
  auto fr3 = intrinsics_preset("fr3");
  ASSERT_TRUE(fr3);
  EXPECT_FALSE(fr3->has_distortion());
  auto kinect = intrinsics_preset("kinect");
  ASSERT_TRUE(kinect);
  EXPECT_DOUBLE_EQ(kinect->cx, 319.5);
  EXPECT_FALSE(intrinsics_preset("fr9"));
}

TEST(Intrinsics, BackprojectionMatchesHandComputedPoints) {
  Intrinsics k = *intrinsics_preset("kinect");
  // Pixel (319.5, 239.5) is the principal point: straight ahead.
  Eigen::Vector3d p = k.backproject(319.5, 239.5, 2.0);
  EXPECT_NEAR(p.x(), 0.0, 1e-12);
  EXPECT_NEAR(p.y(), 0.0, 1e-12);
  EXPECT_NEAR(p.z(), 2.0, 1e-12);
  // Pixel (844.5, 764.5) is 525 px right and down: x = y = z at fx = fy = 525.
  p = k.backproject(844.5, 764.5, 1.5);
  EXPECT_NEAR(p.x(), 1.5, 1e-12);
  EXPECT_NEAR(p.y(), 1.5, 1e-12);
  // Top-left pixel at 1 m: x = -319.5/525, y = -239.5/525.
  p = k.backproject(0, 0, 1.0);
  EXPECT_NEAR(p.x(), -0.608571428571, 1e-9);
  EXPECT_NEAR(p.y(), -0.456190476190, 1e-9);
}

TEST(Intrinsics, ProjectionRoundTripWithinAThousandthOfAPixel) {
  Intrinsics k = *intrinsics_preset("fr1");
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 640), v(0, 480), z(0.3, 8.0);
  double worst = 0;
  for (int i = 0; i < 10000; ++i) {
    const double pu = u(rng), pv = v(rng);
    const Eigen::Vector2d back = k.project(k.backproject(pu, pv, z(rng)));
    worst = std::max(worst, (back - Eigen::Vector2d(pu, pv)).norm());
  }
  EXPECT_LT(worst, 1e-3);
}

TEST(Intrinsics, ReadsJsonAndOpen3dCameraFiles) {
  const std::string dir = test::temp_dir("intrinsics");
  {
    std::ofstream(dir + "/k.json") << R"({"fx": 500, "fy": 501, "cx": 320, "cy": 240, "width": 640, "height": 480,
      "distortion": [0.1, -0.2, 0.001, 0.002, 0.05], "depth_scale": 1000})";
  }
  auto k = load_intrinsics_json(dir + "/k.json");
  ASSERT_TRUE(k) << k.error().message;
  EXPECT_DOUBLE_EQ(k->fy, 501);
  EXPECT_DOUBLE_EQ(k->distortion[3], 0.002);
  EXPECT_DOUBLE_EQ(k->depth_scale, 1000);

  REQUIRE_DATA("augmented_icl_livingroom/camera_primesense.json");
  auto o3d = load_intrinsics_json(test::data_path("augmented_icl_livingroom/camera_primesense.json"));
  ASSERT_TRUE(o3d) << o3d.error().message;
  EXPECT_DOUBLE_EQ(o3d->fx, 525.0);
  EXPECT_DOUBLE_EQ(o3d->fy, 525.0);
  EXPECT_DOUBLE_EQ(o3d->cx, 319.5);
  EXPECT_DOUBLE_EQ(o3d->cy, 239.5);
  EXPECT_EQ(o3d->width, 640);
}

TEST(Intrinsics, RejectsBrokenFiles) {
  const std::string dir = test::temp_dir("intrinsics-bad");
  std::ofstream(dir + "/a.json") << "{not json";
  std::ofstream(dir + "/b.json") << R"({"fx": 500, "fy": 500, "cx": 1})";
  std::ofstream(dir + "/c.json") << R"({"fx": 0, "fy": 500, "cx": 1, "cy": 1, "width": 640, "height": 480})";
  std::ofstream(dir + "/d.json") << R"({"fx": 5, "fy": 500, "cx": 1, "cy": 1, "width": -3, "height": 480})";
  for (const char* f : {"a.json", "b.json", "c.json", "d.json"}) {
    auto k = load_intrinsics_json(dir + "/" + f);
    ASSERT_FALSE(k) << f;
    EXPECT_EQ(k.error().code, ErrorCode::kInvalidInput) << f;
    EXPECT_EQ(k.error().message.find('\n'), std::string::npos);
  }
  EXPECT_EQ(load_intrinsics_json(dir + "/missing.json").error().code, ErrorCode::kNotFound);
  EXPECT_EQ(resolve_intrinsics("nonsense").error().code, ErrorCode::kInvalidArgument);
}

}  // namespace
}  // namespace rgbdcast
