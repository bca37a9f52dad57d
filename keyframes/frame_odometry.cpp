#include "keyframes/frame_odometry.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>

#include "base/stopwatch.h"

namespace rgbdcast {

double translation_m(const Eigen::Matrix4d& t) { return t.topRightCorner<3, 1>().norm(); }

double rotation_deg(const Eigen::Matrix4d& t) {
  const double c = std::clamp((t.topLeftCorner<3, 3>().trace() - 1.0) / 2.0, -1.0, 1.0);
  return std::acos(c) * 180.0 / M_PI;
}

Status OdometryParams::validate() const {
  if (Status s = features.validate(); !s) return s;
  if (Status s = matching.validate(); !s) return s;
  if (Status s = ransac.validate(); !s) return s;
  if (refine_icp)
    if (Status s = icp.validate(); !s) return s;
  if (min_matches < 3) return make_error(ErrorCode::kInvalidArgument, "min_matches must be >= 3");
  return ok_status();
}

Result<PairEstimate> estimate_pair(const RgbdFrame& prev, const FrameFeatures& pf, const RgbdFrame& cur,
                                   const FrameFeatures& cf, const OdometryParams& params) {
  if (Status s = params.validate(); !s) return s.error();
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<FeatureMatch> matches = match_in_window(pf, cf, params.matching);
  const double match_ms = ms_since(t0);
  Result<PairEstimate> r = estimate_motion(prev, pf, cur, cf, matches, params);
  if (r) r->match_ms = match_ms;
  return r;
}

Result<PairEstimate> estimate_motion(const RgbdFrame& prev, const FrameFeatures& pf, const RgbdFrame& cur,
                                     const FrameFeatures& cf, const std::vector<FeatureMatch>& matches,
                                     const OdometryParams& params) {
  if (Status s = params.validate(); !s) return s.error();
  PairEstimate out;
  auto t0 = std::chrono::steady_clock::now();
  out.matches = static_cast<int>(matches.size());
  if (out.matches < params.min_matches) {
    const std::string where = params.matching.window_px > 0
                                  ? "inside the " + std::to_string(params.matching.window_px) + "x" +
                                        std::to_string(params.matching.window_px) + " px window"
                                  : "(no window)";
    return make_error(ErrorCode::kEmpty, std::to_string(out.matches) + " matches " + where + " between frames " +
                                             std::to_string(prev.index) + " and " + std::to_string(cur.index) +
                                             " (need >= " + std::to_string(params.min_matches) + ")");
  }

  t0 = std::chrono::steady_clock::now();
  std::vector<Eigen::Vector3d> src, dst;  // current -> previous
  src.reserve(matches.size());
  dst.reserve(matches.size());
  for (const FeatureMatch& m : matches) {
    src.push_back(cf.points_m[static_cast<size_t>(m.cur)]);
    dst.push_back(pf.points_m[static_cast<size_t>(m.prev)]);
  }
  RansacParams rp = params.ransac;
  rp.min_inliers = std::max(rp.min_inliers, params.min_matches);
  Result<RigidEstimate> est = estimate_rigid_ransac(src, dst, rp);
  out.ransac_ms = ms_since(t0);
  if (!est)
    return make_error(est.error().code, "frames " + std::to_string(prev.index) + " -> " + std::to_string(cur.index) +
                                            ": " + est.error().message);
  out.cur_to_prev = est->transform;
  out.inliers = static_cast<int>(est->inliers.size());
  out.ransac_rms_m = est->rms_m;

  if (params.refine_icp) {
    t0 = std::chrono::steady_clock::now();
    Result<IcpResult> icp = refine_point_to_plane(cur, prev, out.cur_to_prev, params.icp);
    out.icp_ms = ms_since(t0);
    if (!icp) {
      out.note = "ICP not used: " + icp.error().message;
    } else {
      const Eigen::Matrix4d delta = out.cur_to_prev.inverse() * icp->transform;
      if (translation_m(delta) > params.icp_max_correction_m || rotation_deg(delta) > params.icp_max_correction_deg) {
        out.note = "ICP not used: it moved the feature estimate by " + std::to_string(translation_m(delta)) + " m / " +
                   std::to_string(rotation_deg(delta)) + " deg";
      } else {
        out.cur_to_prev = icp->transform;
        out.icp_used = true;
        out.icp_rms_m = icp->rms_m;
      }
    }
  }
  return out;
}

}  // namespace rgbdcast
