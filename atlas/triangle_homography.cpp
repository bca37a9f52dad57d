#include "atlas/triangle_homography.h"

#include <Eigen/Dense>
#include <cmath>

namespace rgbdcast {

bool triangle_texture_map(const Eigen::Vector3d& v0, const Eigen::Vector3d& v1, const Eigen::Vector3d& v2,
                          const Eigen::Matrix3d& K, const std::array<Eigen::Vector2d, 3>& corners,
                          TriangleTextureMap* out, double min_area_m2) {
  if (!(v0.z() > 0.0 && v1.z() > 0.0 && v2.z() > 0.0)) return false;
  const Eigen::Vector3d d1 = v1 - v0, d2 = v2 - v0;
  const Eigen::Vector3d n = d1.cross(d2);
  const double len1 = d1.norm();
  if (!(len1 > 0.0) || !(0.5 * n.norm() > min_area_m2)) return false;
  const Eigen::Vector3d e1 = d1 / len1;
  const Eigen::Vector3d e2 = n.normalized().cross(e1);  // in-plane, towards v2
  out->plane = {Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(len1, 0.0), Eigen::Vector2d(d2.dot(e1), d2.dot(e2))};

  Eigen::Matrix3d plane_to_camera;
  plane_to_camera << e1, e2, v0;
  out->H = K * plane_to_camera;

  // A from three correspondences plane[i] -> corners[i]: solve [a b c; d e f] * [x y 1]^T.
  Eigen::Matrix3d P, Q;
  for (int i = 0; i < 3; ++i) {
    P.col(i) << out->plane[i], 1.0;
    Q.col(i) << corners[i], 1.0;
  }
  const double det = P.determinant();
  if (!(std::abs(det) > 1e-300)) return false;
  out->A = Q * P.inverse();
  out->A.row(2) << 0.0, 0.0, 1.0;
  const Eigen::Matrix3d A_inv = out->A.inverse();
  out->image_from_atlas = out->H * A_inv;
  return out->image_from_atlas.allFinite();
}

double projected_area_px(const Eigen::Vector3d& v0, const Eigen::Vector3d& v1, const Eigen::Vector3d& v2,
                         const Eigen::Matrix3d& K) {
  if (!(v0.z() > 0.0 && v1.z() > 0.0 && v2.z() > 0.0)) return 0.0;
  auto proj = [&](const Eigen::Vector3d& v) -> Eigen::Vector2d {
    const Eigen::Vector3d h = K * v;
    return h.head<2>() / h.z();
  };
  const Eigen::Vector2d a = proj(v0), b = proj(v1), c = proj(v2);
  const Eigen::Vector2d ab = b - a, ac = c - a;
  return 0.5 * std::abs(ab.x() * ac.y() - ab.y() * ac.x());
}

}  // namespace rgbdcast
