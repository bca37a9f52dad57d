#include "tests/atlas/checkerboard_scene.h"

#include <Eigen/Geometry>
#include <cmath>

#include "tests/atlas/right_triangle_mesh.h"

namespace rgbdcast::test {

int CheckerScene::checker(double s, double t) const {
  const long a = static_cast<long>(std::floor(s / square_m)), b = static_cast<long>(std::floor(t / square_m));
  return ((a + b) % 2 == 0) ? 1 : 0;
}

double CheckerScene::edge_distance_m(double s, double t) const {
  auto d = [&](double x) {
    const double r = x / square_m - std::floor(x / square_m);
    return std::min(r, 1 - r) * square_m;
  };
  return std::min(d(s), d(t));
}

Eigen::Vector2d CheckerScene::plane_of(const Eigen::Vector3d& X) const {
  return {U.dot(X - origin), V.dot(X - origin)};
}

Eigen::Vector2d CheckerScene::plane_at_pixel(double u, double v) const {
  const Eigen::Vector3d d((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
  const Eigen::Vector3d n = U.cross(V);
  const double lambda = n.dot(origin) / n.dot(d);
  return plane_of(lambda * d);
}

CheckerScene make_checker_scene(double angle_deg, int quads_s, int quads_t, double half_s, double half_t) {
  CheckerScene c;
  c.half_s = half_s;
  c.half_t = half_t;
  c.k.fx = c.k.fy = 525.0;
  c.k.cx = 319.5;
  c.k.cy = 239.5;
  c.k.width = 640;
  c.k.height = 480;
  const double a = angle_deg * M_PI / 180.0;
  c.origin = Eigen::Vector3d(0, 0, 1.2);
  c.U = Eigen::Vector3d(std::cos(a), 0, std::sin(a));
  c.V = Eigen::Vector3d(0, 1, 0);
  c.image.create(c.k.height, c.k.width, CV_8UC3);
  for (int y = 0; y < c.k.height; ++y)
    for (int x = 0; x < c.k.width; ++x) {
      int sum = 0, n = 0;
      for (int sy = 0; sy < 4; ++sy)
        for (int sx = 0; sx < 4; ++sx) {
          const Eigen::Vector2d st = c.plane_at_pixel(x - 0.375 + 0.25 * sx, y - 0.375 + 0.25 * sy);
          const bool on = std::abs(st.x()) <= c.half_s && std::abs(st.y()) <= c.half_t;
          sum += on ? (c.checker(st.x(), st.y()) ? 230 : 25) : 128;
          ++n;
        }
      const auto g = static_cast<std::uint8_t>(sum / n);
      c.image.at<cv::Vec3b>(y, x) = cv::Vec3b(g, g, g);
    }
  for (int j = 0; j <= quads_t; ++j)
    for (int i = 0; i <= quads_s; ++i) {
      const double s = -c.half_s + 2 * c.half_s * i / quads_s, t = -c.half_t + 2 * c.half_t * j / quads_t;
      c.mesh.positions.push_back((c.origin + s * c.U + t * c.V).cast<float>());
    }
  for (int j = 0; j < quads_t; ++j)
    for (int i = 0; i < quads_s; ++i) {
      const std::uint32_t p = j * (quads_s + 1) + i, row = quads_s + 1;
      c.mesh.indices.insert(c.mesh.indices.end(), {p, p + 1, p + row, p + 1, p + row + 1, p + row});
    }
  return c;
}

Mesh checker_right_triangle_mesh(const CheckerScene& c, int min_side_px, int max_side_px) {
  const PointAt on_board = [&](int x, int y, Eigen::Vector3f* p) {
    const Eigen::Vector2d st = c.plane_at_pixel(x, y);
    if (std::abs(st.x()) > c.half_s || std::abs(st.y()) > c.half_t) return false;
    *p = (c.origin + st.x() * c.U + st.y() * c.V).cast<float>();
    return true;
  };
  // Split a block when a corner is off the board, and in a fixed pseudo-random pattern, so that sizes mix.
  const SplitBlock split = [&](int x, int y, int s) {
    Eigen::Vector3f p;
    for (int j = 0; j <= 1; ++j)
      for (int i = 0; i <= 1; ++i)
        if (!on_board(x + i * s, y + j * s, &p)) return true;
    // Multiplied as unsigned: wraps modulo 2^32 by definition (the int products overflowed, which UBSan reports).
    const unsigned h = static_cast<unsigned>(x) * 73856093u ^ static_cast<unsigned>(y) * 19349663u ^
                       static_cast<unsigned>(s) * 83492791u;
    return (h >> 4) % 3 == 0;
  };
  RightTriangleMeshOptions o;
  o.min_side_px = min_side_px;
  o.max_side_px = max_side_px;
  o.min_diagonal_side_px = 2 * min_side_px;
  o.max_depth_ratio = 1e9;  // no depth jump on a board
  return right_triangle_mesh(c.k.width, c.k.height, on_board, split, o);
}

}  // namespace rgbdcast::test
