#pragma once
// Point-to-plane ICP between two RGB-D frames with projective data association (as in KinectFusion): source
// pixels (every pixel_step-th) are moved by the current estimate, projected into the target camera, and paired with
// the target pixel they land on; pairs further apart than the distance gate or with normals more than the angle
// gate apart are dropped. Each iteration solves the linearised 6-DoF point-to-plane problem (Huber-weighted).
// It refines a feature-based estimate; it does not find a motion from scratch (the initial guess must be within
// a few centimetres / degrees).
#include <Eigen/Core>

#include "input/frame.h"
#include "scene/result.h"

namespace rgbdcast {

struct IcpParams {
  int max_iterations = 30;
  int pixel_step = 2;            // source subsampling
  int image_step = 1;            // both frames decimated to every image_step-th pixel first (intrinsics
                                 // scaled): 2 costs a quarter, for live tracking
  double max_distance_m = 0.08;  // correspondence gate in the first iteration ...
  double min_distance_m = 0.03;  // ... shrinking to this. Not below the depth noise: a 1 cm gate truncates
                                 // noisy Kinect depth one-sidedly and biased augmented ICL by 1.2 cm / 0.5 deg
  double max_normal_angle_deg = 30.0;
  double huber_m = 0.005;    // residuals above this are down-weighted
  double max_depth_m = 6.0;  // ignore points further away (noise grows with z^2)
  int min_correspondences = 500;
  double convergence_m = 1e-5;  // stop when the update moves points less than this (translation + angle)
  Status validate() const;
};

struct IcpResult {
  Eigen::Matrix4d transform = Eigen::Matrix4d::Identity();  // source camera -> target camera
  int correspondences = 0;                                  // in the last iteration
  double rms_m = 0.0;                                       // point-to-plane RMS of the last iteration
  int iterations = 0;
  bool converged = false;
};

// Errors: kInvalidInput (frames without CV_32F depth or of different sizes), kEmpty (fewer than
// min_correspondences pairs: no overlap at the initial estimate), kInvalidArgument (bad params or initial guess).
Result<IcpResult> refine_point_to_plane(const RgbdFrame& source, const RgbdFrame& target,
                                        const Eigen::Matrix4d& initial_source_to_target, const IcpParams& params);

}  // namespace rgbdcast
