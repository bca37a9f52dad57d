#pragma once
// Rigid transform between matched 3D points: RANSAC over minimal 3-point sets, then a least-squares refit
// (Umeyama/Kabsch, no scale) on the inliers. A match is an inlier when |T * src - dst| is below a threshold that
// grows with depth like the Kinect's axial noise (Nguyen et al. 2012: sigma_z = 0.0012 + 0.0019 (z - 0.4)^2 m).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "scene/result.h"

namespace rgbdcast {

struct RansacParams {
  int max_iterations = 2000;
  double confidence = 0.999;      // stop early once this probability of an all-inlier sample is reached
  double min_threshold_m = 0.01;  // inlier threshold floor
  double noise_sigmas = 3.0;      // threshold = max(floor, noise_sigmas * combined depth noise of the two points)
  int min_inliers = 5;            // fewer inliers than this is a failure (paper: N <= 4 matches is a skip)
  uint32_t seed = 1;              // deterministic sampling
  Status validate() const;
};

// Kinect axial depth noise (1 sigma, metres) at depth z.
double kinect_depth_sigma_m(double z_m);
// The inlier threshold for a pair of points at depths z_src and z_dst.
double inlier_threshold_m(double z_src_m, double z_dst_m, const RansacParams& params);

struct RigidEstimate {
  Eigen::Matrix4d transform = Eigen::Matrix4d::Identity();  // maps src points onto dst points
  std::vector<int> inliers;                                 // indices into the input lists
  double rms_m = 0.0;                                       // RMS residual over the inliers after the refit
  int iterations = 0;
};

// Errors: kInvalidArgument (lists of different sizes, non-finite points), kEmpty (fewer than 3 points, or fewer
// than min_inliers inliers: the message gives the counts).
Result<RigidEstimate> estimate_rigid_ransac(const std::vector<Eigen::Vector3d>& src,
                                            const std::vector<Eigen::Vector3d>& dst, const RansacParams& params);

// Least-squares rigid fit (Umeyama without scale) of src onto dst over the given indices (all when empty).
Eigen::Matrix4d fit_rigid(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst,
                          const std::vector<int>& indices = {});

}  // namespace rgbdcast
