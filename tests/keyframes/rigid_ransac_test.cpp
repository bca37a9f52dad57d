// RANSAC + Umeyama on synthetic matches with a known rigid transform.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <random>

#include "keyframes/frame_odometry.h"
#include "keyframes/rigid_ransac.h"

namespace rgbdcast {
namespace {

struct Synthetic {
  std::vector<Eigen::Vector3d> src, dst;
  std::vector<bool> outlier;
  Eigen::Matrix4d truth = Eigen::Matrix4d::Identity();
};

// n points in a Kinect-like frustum (z 0.8-4 m); dst = truth * src + depth-dependent noise; a fraction of the
// matches replaced by random points of the same frustum (wrong matches).
Synthetic make_synthetic(int n, double outlier_fraction, double noise_sigmas, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uz(0.8, 4.0), uxy(-0.5, 0.5), unit(0, 1);
  std::normal_distribution<double> gauss(0, 1);
  Synthetic s;
  const Eigen::AngleAxisd rot(8.0 * M_PI / 180.0, Eigen::Vector3d(0.3, -1.0, 0.2).normalized());
  s.truth.topLeftCorner<3, 3>() = rot.toRotationMatrix();
  s.truth.topRightCorner<3, 1>() = Eigen::Vector3d(0.06, -0.03, 0.12);
  auto random_point = [&] {
    const double z = uz(rng);
    return Eigen::Vector3d(uxy(rng) * z * 1.2, uxy(rng) * z * 0.9, z);
  };
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d p = random_point();
    Eigen::Vector3d q = s.truth.topLeftCorner<3, 3>() * p + s.truth.topRightCorner<3, 1>();
    q += noise_sigmas * kinect_depth_sigma_m(q.z()) * Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)) /
         std::sqrt(3.0);
    const bool out = unit(rng) < outlier_fraction;
    s.src.push_back(p);
    s.dst.push_back(out ? random_point() : q);
    s.outlier.push_back(out);
  }
  return s;
}

// The error the least-squares refit is expected to make, from the noise make_synthetic injects: linearized around
// the truth, dst_i = R src_i + t + n_i with n_i ~ N(0, s_i^2 I), s_i = noise_sigmas * sigma_z(z_i) / sqrt(3). The
// refit's (rotation vector, translation) error is x = H^-1 sum J_i^T n_i with J_i = [-[R src_i]x, I] and
// H = sum J_i^T J_i, so Cov(x) = H^-1 (sum s_i^2 J_i^T J_i) H^-1. The bounds are the 1 - 1e-6 ellipsoid of each
// 3-vector along its widest axis: sqrt(chi2_3(1 - 1e-6) * lambda_max), chi2_3(1 - 1e-6) = 30.66. A correct fit
// exceeds one of them with probability under 1e-6 per seed and quantity.
struct ErrorBounds {
  double rotation_deg = 0, translation_m = 0;
};
ErrorBounds refit_error_bounds(const Synthetic& s, const std::vector<int>& used, double noise_sigmas) {
  const Eigen::Matrix3d R = s.truth.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = s.truth.topRightCorner<3, 1>();
  Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero(), N = H;
  for (int i : used) {
    const Eigen::Vector3d a = R * s.src[static_cast<size_t>(i)];
    Eigen::Matrix<double, 3, 6> J;
    J.leftCols<3>() << 0, a.z(), -a.y(), -a.z(), 0, a.x(), a.y(), -a.x(), 0;  // -[a]x
    J.rightCols<3>().setIdentity();
    const double sigma = noise_sigmas * kinect_depth_sigma_m((a + t).z()) / std::sqrt(3.0);
    H += J.transpose() * J;
    N += sigma * sigma * J.transpose() * J;
  }
  const Eigen::Matrix<double, 6, 6> Hi = H.inverse(), cov = Hi * N * Hi;
  constexpr double kChi2Dof3At1e6 = 30.66;
  auto widest = [&](int block) {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov.block<3, 3>(block, block));
    return std::sqrt(kChi2Dof3At1e6 * eig.eigenvalues().maxCoeff());
  };
  return {widest(0) * 180.0 / M_PI, widest(3)};
}

TEST(RigidRansac, RecoversTransformWith30PercentOutliers) {
  for (uint32_t seed : {1u, 2u, 3u}) {
    const Synthetic s = make_synthetic(300, 0.30, 1.0, seed);
    const int true_outliers = static_cast<int>(std::count(s.outlier.begin(), s.outlier.end(), true));
    Result<RigidEstimate> est = estimate_rigid_ransac(s.src, s.dst, RansacParams{});
    ASSERT_TRUE(est) << est.error().message;
    const Eigen::Matrix4d err = s.truth.inverse() * est->transform;
    // Bounds from the injected noise over the matches the refit used (a wrong match that slipped in lies within
    // the inlier threshold; at most 3 of them are allowed below).
    const ErrorBounds bound = refit_error_bounds(s, est->inliers, 1.0);
    EXPECT_LT(rotation_deg(err), bound.rotation_deg) << "seed " << seed;
    EXPECT_LT(translation_m(err), bound.translation_m) << "seed " << seed;
    // Every true inlier is found (noise is 1 sigma, threshold 3 sigma), and few wrong matches slip in by chance.
    int wrong = 0;
    for (int i : est->inliers) wrong += s.outlier[static_cast<size_t>(i)] ? 1 : 0;
    EXPECT_GE(static_cast<int>(est->inliers.size()) - wrong, (300 - true_outliers) * 95 / 100);
    EXPECT_LE(wrong, 3);
    std::printf(
        "seed %u: %d true outliers, %zu inliers (%d wrong), rotation error %.4f deg (bound %.4f), "
        "translation %.5f m (bound %.5f), %d iterations\n",
        seed, true_outliers, est->inliers.size(), wrong, rotation_deg(err), bound.rotation_deg, translation_m(err),
        bound.translation_m, est->iterations);
  }
}

TEST(RigidRansac, ExactDataGivesExactTransform) {
  const Synthetic s = make_synthetic(50, 0.0, 0.0, 7);
  Result<RigidEstimate> est = estimate_rigid_ransac(s.src, s.dst, RansacParams{});
  ASSERT_TRUE(est);
  EXPECT_EQ(est->inliers.size(), 50u);
  EXPECT_LT((est->transform - s.truth).norm(), 1e-9);
}

TEST(RigidRansac, BadInputGivesErrors) {
  const Synthetic s = make_synthetic(20, 0.0, 0.0, 9);
  std::vector<Eigen::Vector3d> shorter(s.dst.begin(), s.dst.end() - 1);
  Result<RigidEstimate> a = estimate_rigid_ransac(s.src, shorter, RansacParams{});
  ASSERT_FALSE(a);
  EXPECT_EQ(a.error().code, ErrorCode::kInvalidArgument);

  std::vector<Eigen::Vector3d> two(s.src.begin(), s.src.begin() + 2);
  Result<RigidEstimate> b = estimate_rigid_ransac(two, two, RansacParams{});
  ASSERT_FALSE(b);
  EXPECT_EQ(b.error().code, ErrorCode::kEmpty);
  EXPECT_NE(b.error().message.find("2 matches"), std::string::npos) << b.error().message;

  std::vector<Eigen::Vector3d> nan = s.src;
  nan[3].x() = std::numeric_limits<double>::quiet_NaN();
  Result<RigidEstimate> c = estimate_rigid_ransac(nan, s.dst, RansacParams{});
  ASSERT_FALSE(c);
  EXPECT_EQ(c.error().code, ErrorCode::kInvalidArgument);

  // All matches wrong: no consistent model.
  const Synthetic junk = make_synthetic(40, 1.0, 0.0, 11);
  Result<RigidEstimate> d = estimate_rigid_ransac(junk.src, junk.dst, RansacParams{});
  ASSERT_FALSE(d);
  EXPECT_EQ(d.error().code, ErrorCode::kEmpty);

  RansacParams bad;
  bad.min_threshold_m = -1;
  EXPECT_FALSE(estimate_rigid_ransac(s.src, s.dst, bad));
}

TEST(RigidRansac, ThresholdGrowsWithDepth) {
  const RansacParams p;
  EXPECT_DOUBLE_EQ(inlier_threshold_m(1.0, 1.0, p), p.min_threshold_m);  // near: the floor
  EXPECT_GT(inlier_threshold_m(4.0, 4.0, p), 0.05);                      // far: 3 x sqrt(2) x 2.6 cm
}

}  // namespace
}  // namespace rgbdcast
