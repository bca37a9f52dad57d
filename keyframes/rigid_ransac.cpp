#include "keyframes/rigid_ransac.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>
#include <string>

namespace rgbdcast {

Status RansacParams::validate() const {
  if (max_iterations < 1) return make_error(ErrorCode::kInvalidArgument, "RANSAC iterations must be >= 1");
  if (!(confidence > 0 && confidence < 1))
    return make_error(ErrorCode::kInvalidArgument, "RANSAC confidence must be in (0, 1)");
  if (!(min_threshold_m > 0) || !std::isfinite(min_threshold_m))
    return make_error(ErrorCode::kInvalidArgument, "RANSAC threshold must be > 0 m");
  if (!(noise_sigmas >= 0) || !std::isfinite(noise_sigmas))
    return make_error(ErrorCode::kInvalidArgument, "RANSAC noise multiplier must be >= 0");
  if (min_inliers < 3) return make_error(ErrorCode::kInvalidArgument, "RANSAC needs min_inliers >= 3");
  return ok_status();
}

double kinect_depth_sigma_m(double z_m) { return 0.0012 + 0.0019 * (z_m - 0.4) * (z_m - 0.4); }

double inlier_threshold_m(double z_src_m, double z_dst_m, const RansacParams& p) {
  const double s1 = kinect_depth_sigma_m(z_src_m), s2 = kinect_depth_sigma_m(z_dst_m);
  return std::max(p.min_threshold_m, p.noise_sigmas * std::sqrt(s1 * s1 + s2 * s2));
}

Eigen::Matrix4d fit_rigid(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst,
                          const std::vector<int>& indices) {
  const size_t n = indices.empty() ? src.size() : indices.size();
  Eigen::Matrix3Xd a(3, n), b(3, n);
  for (size_t i = 0; i < n; ++i) {
    const size_t k = indices.empty() ? i : static_cast<size_t>(indices[i]);
    a.col(static_cast<Eigen::Index>(i)) = src[k];
    b.col(static_cast<Eigen::Index>(i)) = dst[k];
  }
  return Eigen::umeyama(a, b, false);
}

namespace {

std::vector<int> inliers_of(const Eigen::Matrix4d& t, const std::vector<Eigen::Vector3d>& src,
                            const std::vector<Eigen::Vector3d>& dst, const std::vector<double>& thr, double* sq_sum) {
  std::vector<int> in;
  const Eigen::Matrix3d r = t.topLeftCorner<3, 3>();
  const Eigen::Vector3d tr = t.topRightCorner<3, 1>();
  double s = 0;
  for (size_t i = 0; i < src.size(); ++i) {
    const double e2 = (r * src[i] + tr - dst[i]).squaredNorm();
    if (e2 < thr[i] * thr[i]) {
      in.push_back(static_cast<int>(i));
      s += e2;
    }
  }
  if (sq_sum) *sq_sum = s;
  return in;
}

// A minimal sample is usable when its points are not (nearly) collinear and its pairwise distances agree between
// the two frames (a rigid motion preserves them): cheap rejection before fitting.
bool usable_sample(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst, const int idx[3],
                   const std::vector<double>& thr) {
  for (int a = 0; a < 3; ++a)
    for (int b = a + 1; b < 3; ++b) {
      const double ds = (src[idx[a]] - src[idx[b]]).norm(), dd = (dst[idx[a]] - dst[idx[b]]).norm();
      if (std::abs(ds - dd) > 2.0 * std::max(thr[idx[a]], thr[idx[b]])) return false;
      if (ds < 1e-3) return false;
    }
  const double area = (src[idx[1]] - src[idx[0]]).cross(src[idx[2]] - src[idx[0]]).norm();
  return area > 1e-6;  // 2 x area in m^2: rejects collinear triples
}

}  // namespace

Result<RigidEstimate> estimate_rigid_ransac(const std::vector<Eigen::Vector3d>& src,
                                            const std::vector<Eigen::Vector3d>& dst, const RansacParams& params) {
  if (Status s = params.validate(); !s) return s.error();
  if (src.size() != dst.size())
    return make_error(ErrorCode::kInvalidArgument, "RANSAC: " + std::to_string(src.size()) + " source points but " +
                                                       std::to_string(dst.size()) + " destination points");
  for (size_t i = 0; i < src.size(); ++i)
    if (!src[i].allFinite() || !dst[i].allFinite())
      return make_error(ErrorCode::kInvalidArgument, "RANSAC: point " + std::to_string(i) + " is not finite");
  const size_t n = src.size();
  if (n < 3 || static_cast<int>(n) < params.min_inliers)
    return make_error(ErrorCode::kEmpty, "RANSAC: " + std::to_string(n) + " matches, need at least " +
                                             std::to_string(std::max(3, params.min_inliers)));

  std::vector<double> thr(n);
  for (size_t i = 0; i < n; ++i) thr[i] = inlier_threshold_m(src[i].z(), dst[i].z(), params);

  std::mt19937 rng(params.seed);
  std::uniform_int_distribution<int> pick(0, static_cast<int>(n) - 1);
  std::vector<int> best;
  double best_sq = 0;
  int iterations = 0, needed = params.max_iterations;
  for (; iterations < needed; ++iterations) {
    int idx[3];
    idx[0] = pick(rng);
    do idx[1] = pick(rng);
    while (idx[1] == idx[0]);
    do idx[2] = pick(rng);
    while (idx[2] == idx[0] || idx[2] == idx[1]);
    if (!usable_sample(src, dst, idx, thr)) continue;
    const Eigen::Matrix4d t = fit_rigid(src, dst, {idx[0], idx[1], idx[2]});
    double sq = 0;
    std::vector<int> in = inliers_of(t, src, dst, thr, &sq);
    if (in.size() > best.size() || (in.size() == best.size() && sq < best_sq)) {
      best = std::move(in);
      best_sq = sq;
      const double w = static_cast<double>(best.size()) / static_cast<double>(n);
      const double p_fail = 1.0 - w * w * w;
      if (p_fail <= 1e-12)
        needed = iterations + 1;
      else
        needed = std::min(params.max_iterations,
                          static_cast<int>(std::ceil(std::log(1.0 - params.confidence) / std::log(p_fail))));
    }
  }
  if (static_cast<int>(best.size()) < params.min_inliers)
    return make_error(ErrorCode::kEmpty, "RANSAC: best model has " + std::to_string(best.size()) + " inliers of " +
                                             std::to_string(n) + " matches, need " +
                                             std::to_string(params.min_inliers));

  // Least-squares refit on the inliers, then once more on the refit's inliers.
  RigidEstimate est;
  est.iterations = iterations;
  est.inliers = best;
  for (int round = 0; round < 3; ++round) {
    est.transform = fit_rigid(src, dst, est.inliers);
    double sq = 0;
    std::vector<int> in = inliers_of(est.transform, src, dst, thr, &sq);
    if (static_cast<int>(in.size()) < params.min_inliers) break;
    const bool same = in == est.inliers;
    est.inliers = std::move(in);
    est.rms_m = std::sqrt(sq / static_cast<double>(est.inliers.size()));
    if (same) break;
  }
  return est;
}

}  // namespace rgbdcast
