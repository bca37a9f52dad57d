#include "keyframes/icp_refine.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace rgbdcast {

Status IcpParams::validate() const {
  if (max_iterations < 1 || pixel_step < 1 || image_step < 1 || image_step > 16)
    return make_error(ErrorCode::kInvalidArgument, "ICP: iterations and step must be >= 1");
  if (!(min_distance_m > 0) || !(max_distance_m >= min_distance_m))
    return make_error(ErrorCode::kInvalidArgument, "ICP: need 0 < min_distance_m <= max_distance_m");
  if (!(max_normal_angle_deg > 0 && max_normal_angle_deg <= 180) || !(huber_m > 0) || !(max_depth_m > 0))
    return make_error(ErrorCode::kInvalidArgument, "ICP: normal angle, Huber width and max depth must be positive");
  return ok_status();
}

namespace {

// Vertex and normal maps of a frame (camera frame). Normals from central differences; NaN where a neighbour is
// missing or across a depth edge.
struct Maps {
  cv::Mat vertex, normal;  // CV_32FC3
};

// Normals only on every step-th pixel (the source is subsampled; the target needs step 1).
Maps make_maps(const RgbdFrame& f, double max_depth_m, int step) {
  const int w = f.depth_m.cols, h = f.depth_m.rows;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  Maps m;
  m.vertex.create(h, w, CV_32FC3);
  m.normal.create(h, w, CV_32FC3);
  const Intrinsics& k = f.intrinsics;
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      cv::Vec3f p(nan, nan, nan);
      if (!f.xyz_m.empty()) {
        p = f.xyz_m.at<cv::Vec3f>(v, u);
        if (!(p[2] > 0) || p[2] > max_depth_m) p = cv::Vec3f(nan, nan, nan);
      } else {
        const float z = f.depth_m.at<float>(v, u);
        if (z > 0 && z <= max_depth_m)
          p = cv::Vec3f(static_cast<float>((u - k.cx) / k.fx * z), static_cast<float>((v - k.cy) / k.fy * z), z);
      }
      m.vertex.at<cv::Vec3f>(v, u) = p;
    }
  m.normal.setTo(cv::Scalar::all(nan));
  for (int v = 0; v < h; v += step)
    for (int u = 0; u < w; u += step) {
      cv::Vec3f n(nan, nan, nan);
      if (u > 0 && v > 0 && u + 1 < w && v + 1 < h) {
        const cv::Vec3f c = m.vertex.at<cv::Vec3f>(v, u);
        const cv::Vec3f l = m.vertex.at<cv::Vec3f>(v, u - 1), r = m.vertex.at<cv::Vec3f>(v, u + 1);
        const cv::Vec3f t = m.vertex.at<cv::Vec3f>(v - 1, u), b = m.vertex.at<cv::Vec3f>(v + 1, u);
        const float edge = 0.05f * c[2];  // a neighbour this far away in depth is across an edge
        if (std::isfinite(c[2]) && std::isfinite(l[2]) && std::isfinite(r[2]) && std::isfinite(t[2]) &&
            std::isfinite(b[2]) && std::abs(l[2] - c[2]) < edge && std::abs(r[2] - c[2]) < edge &&
            std::abs(t[2] - c[2]) < edge && std::abs(b[2] - c[2]) < edge) {
          const Eigen::Vector3f dx(r[0] - l[0], r[1] - l[1], r[2] - l[2]), dy(b[0] - t[0], b[1] - t[1], b[2] - t[2]);
          Eigen::Vector3f nn = dx.cross(dy);
          const float len = nn.norm();
          if (len > 0) {
            nn /= len;
            // Face the camera (the view ray is +z from the origin towards c).
            if (nn.dot(Eigen::Vector3f(c[0], c[1], c[2])) > 0) nn = -nn;
            n = cv::Vec3f(nn.x(), nn.y(), nn.z());
          }
        }
      }
      m.normal.at<cv::Vec3f>(v, u) = n;
    }
  return m;
}

// Every step-th pixel of a frame's geometry (depth, organised points), with intrinsics for the smaller grid:
// pixel u' = u / step, so fx' = fx / step and cx' = cx / step.
RgbdFrame decimate(const RgbdFrame& f, int step) {
  RgbdFrame d;
  d.index = f.index;
  const int w = f.depth_m.cols / step, h = f.depth_m.rows / step;
  d.depth_m.create(h, w, CV_32FC1);
  if (!f.xyz_m.empty()) d.xyz_m.create(h, w, CV_32FC3);
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      d.depth_m.at<float>(v, u) = f.depth_m.at<float>(v * step, u * step);
      if (!f.xyz_m.empty()) d.xyz_m.at<cv::Vec3f>(v, u) = f.xyz_m.at<cv::Vec3f>(v * step, u * step);
    }
  d.intrinsics = f.intrinsics;
  d.intrinsics.fx /= step;
  d.intrinsics.fy /= step;
  d.intrinsics.cx /= step;
  d.intrinsics.cy /= step;
  return d;
}

Eigen::Matrix4d se3_exp(const Eigen::Matrix<double, 6, 1>& x) {
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  const Eigen::Vector3d w = x.head<3>();
  const double angle = w.norm();
  if (angle > 0) t.topLeftCorner<3, 3>() = Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
  t.topRightCorner<3, 1>() = x.tail<3>();
  return t;
}

}  // namespace

Result<IcpResult> refine_point_to_plane(const RgbdFrame& source, const RgbdFrame& target,
                                        const Eigen::Matrix4d& initial, const IcpParams& params) {
  if (Status s = params.validate(); !s) return s.error();
  if (!initial.allFinite()) return make_error(ErrorCode::kInvalidArgument, "ICP: initial transform is not finite");
  for (const RgbdFrame* f : {&source, &target})
    if (f->depth_m.empty() || f->depth_m.type() != CV_32FC1)
      return make_error(ErrorCode::kInvalidInput, "ICP: frame " + std::to_string(f->index) + " has no CV_32F depth");

  const RgbdFrame small_source = params.image_step > 1 ? decimate(source, params.image_step) : RgbdFrame{};
  const RgbdFrame small_target = params.image_step > 1 ? decimate(target, params.image_step) : RgbdFrame{};
  const RgbdFrame& s_frame = params.image_step > 1 ? small_source : source;
  const RgbdFrame& t_frame = params.image_step > 1 ? small_target : target;
  const Maps src = make_maps(s_frame, params.max_depth_m, params.pixel_step);
  const Maps dst = make_maps(t_frame, params.max_depth_m, 1);
  const Intrinsics& k = t_frame.intrinsics;
  const int tw = dst.vertex.cols, th = dst.vertex.rows;
  const double cos_gate = std::cos(params.max_normal_angle_deg * M_PI / 180.0);

  IcpResult res;
  res.transform = initial;
  for (int it = 0; it < params.max_iterations; ++it) {
    // Gate shrinks geometrically from max to min over the first half of the iterations.
    const double f = params.max_iterations > 1 ? std::min(1.0, 2.0 * it / (params.max_iterations - 1)) : 1.0;
    const double gate = params.max_distance_m * std::pow(params.min_distance_m / params.max_distance_m, f);
    const Eigen::Matrix3d r = res.transform.topLeftCorner<3, 3>();
    const Eigen::Vector3d t = res.transform.topRightCorner<3, 1>();
    Eigen::Matrix<double, 6, 6> a = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> b = Eigen::Matrix<double, 6, 1>::Zero();
    int count = 0;
    double sq = 0;
    for (int v = 0; v < src.vertex.rows; v += params.pixel_step)
      for (int u = 0; u < src.vertex.cols; u += params.pixel_step) {
        const cv::Vec3f sp = src.vertex.at<cv::Vec3f>(v, u);
        const cv::Vec3f sn = src.normal.at<cv::Vec3f>(v, u);
        if (!std::isfinite(sp[2]) || !std::isfinite(sn[2])) continue;
        const Eigen::Vector3d p = r * Eigen::Vector3d(sp[0], sp[1], sp[2]) + t;
        if (p.z() <= 0) continue;
        const int tu = static_cast<int>(std::lround(k.fx * p.x() / p.z() + k.cx));
        const int tv = static_cast<int>(std::lround(k.fy * p.y() / p.z() + k.cy));
        if (tu < 0 || tv < 0 || tu >= tw || tv >= th) continue;
        const cv::Vec3f qv = dst.vertex.at<cv::Vec3f>(tv, tu);
        const cv::Vec3f qn = dst.normal.at<cv::Vec3f>(tv, tu);
        if (!std::isfinite(qv[2]) || !std::isfinite(qn[2])) continue;
        const Eigen::Vector3d q(qv[0], qv[1], qv[2]), n(qn[0], qn[1], qn[2]);
        if ((p - q).norm() > gate) continue;
        if ((r * Eigen::Vector3d(sn[0], sn[1], sn[2])).dot(n) < cos_gate) continue;
        const double e = n.dot(p - q);
        Eigen::Matrix<double, 6, 1> j;
        j.head<3>() = p.cross(n);
        j.tail<3>() = n;
        const double w = std::abs(e) <= params.huber_m ? 1.0 : params.huber_m / std::abs(e);
        a += w * j * j.transpose();
        b += w * j * e;
        sq += e * e;
        ++count;
      }
    res.correspondences = count;
    res.iterations = it + 1;
    if (count < params.min_correspondences)
      return make_error(ErrorCode::kEmpty, "ICP: " + std::to_string(count) + " correspondences in iteration " +
                                               std::to_string(it + 1) + ", need " +
                                               std::to_string(params.min_correspondences) + " (too little overlap)");
    res.rms_m = std::sqrt(sq / count);
    const Eigen::Matrix<double, 6, 1> x = a.ldlt().solve(-b);
    if (!x.allFinite()) return make_error(ErrorCode::kInternal, "ICP: degenerate geometry (singular system)");
    res.transform = se3_exp(x) * res.transform;
    if (x.head<3>().norm() + x.tail<3>().norm() < params.convergence_m && f >= 1.0) {
      res.converged = true;
      break;
    }
  }
  return res;
}

}  // namespace rgbdcast
