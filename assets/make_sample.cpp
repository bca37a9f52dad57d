// Makes rgbdcast's built-in sample: a CPU ray-cast textured room seen by a Kinect-like camera moving slowly, written
// in the TUM RGB-D layout (rgb.txt, depth.txt, rgb/, depth/, groundtruth.txt; depth 5000 = 1 m; intrinsics = the
// Kinect default 525/525/319.5/239.5). Kinect-like artefacts: depth noise growing with z^2 (Khoshelham & Elberink
// 2012: sigma = 1.425e-3 z^2), disparity quantisation, no reading beyond 4.5 m or at grazing angles, holes along
// depth edges (the projector's shadow) and a few random dropouts. Deterministic (fixed seed).
//
// usage: make_sample OUT_DIR [frames]
#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <random>

namespace {

struct Hit {
  double t = 1e30;
  Eigen::Vector3d n;
  int material = -1;
};

// Room: x in [-1.3, 1.3], y in [-1.5, 0.6] (y down: floor at y = 0.6), z in [-1, 2.4]. A crate and a ball on the
// floor, a checkerboard poster on the back wall.
void intersect_plane(const Eigen::Vector3d& o, const Eigen::Vector3d& d, int axis, double value, int material,
                     const Eigen::Vector3d& normal, Hit* hit) {
  if (std::abs(d[axis]) < 1e-12) return;
  const double t = (value - o[axis]) / d[axis];
  if (t > 1e-6 && t < hit->t) *hit = {t, normal, material};
}

void intersect_box(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& lo,
                   const Eigen::Vector3d& hi, int material, Hit* hit) {
  double tmin = -1e30, tmax = 1e30;
  int axis = 0;
  double sign = 1;
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d[a]) < 1e-12) {
      if (o[a] < lo[a] || o[a] > hi[a]) return;
      continue;
    }
    double t0 = (lo[a] - o[a]) / d[a], t1 = (hi[a] - o[a]) / d[a];
    double s = -1;
    if (t0 > t1) {
      std::swap(t0, t1);
      s = 1;
    }
    if (t0 > tmin) {
      tmin = t0;
      axis = a;
      sign = s;
    }
    tmax = std::min(tmax, t1);
  }
  if (tmin > tmax || tmin < 1e-6 || tmin >= hit->t) return;
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  n[axis] = sign;
  *hit = {tmin, n, material};
}

void intersect_sphere(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& c, double r,
                      int material, Hit* hit) {
  const Eigen::Vector3d oc = o - c;
  const double b = oc.dot(d), cc = oc.squaredNorm() - r * r, disc = b * b - cc;
  if (disc < 0) return;
  const double t = -b - std::sqrt(disc);
  if (t > 1e-6 && t < hit->t) *hit = {t, (o + t * d - c).normalized(), material};
}

Hit trace(const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  Hit h;
  intersect_plane(o, d, 1, 0.6, 0, {0, -1, 0}, &h);                  // floor
  intersect_plane(o, d, 1, -1.5, 1, {0, 1, 0}, &h);                  // ceiling
  intersect_plane(o, d, 2, 2.4, 2, {0, 0, -1}, &h);                  // back wall
  intersect_plane(o, d, 0, -1.3, 3, {1, 0, 0}, &h);                  // left wall
  intersect_plane(o, d, 0, 1.3, 4, {-1, 0, 0}, &h);                  // right wall
  intersect_plane(o, d, 2, -1.0, 2, {0, 0, 1}, &h);                  // wall behind the camera
  intersect_box(o, d, {-0.75, 0.1, 1.3}, {-0.2, 0.6, 1.85}, 5, &h);  // a crate
  intersect_sphere(o, d, {0.45, 0.35, 1.5}, 0.25, 6, &h);            // a ball
  return h;
}

cv::Vec3b shade(int material, const Eigen::Vector3d& p, const Eigen::Vector3d& n) {
  auto checker = [](double a, double b, double s) { return (int(std::floor(a / s)) + int(std::floor(b / s))) & 1; };
  double r = 0, g = 0, b = 0;
  switch (material) {
    case 0: {  // floor: wooden planks
      const double plank = std::floor(p.x() / 0.25);
      const double grain = 0.5 + 0.5 * std::sin(p.z() * 40.0 + plank * 1.7 + std::sin(p.z() * 7.0 + plank));
      r = 150 + 50 * grain - 15 * std::fmod(std::abs(plank), 3.0);
      g = 100 + 35 * grain;
      b = 60 + 20 * grain;
      if (std::abs(p.x() / 0.25 - std::round(p.x() / 0.25)) < 0.03) r *= 0.5, g *= 0.5, b *= 0.5;
      break;
    }
    case 1:
      r = g = b = 225;
      break;   // ceiling
    case 2: {  // back wall: a checkerboard poster on a light wall
      const bool in_poster = p.x() > -0.8 && p.x() < 0.8 && p.y() > -0.8 && p.y() < 0.2;
      if (in_poster) {
        const int c = checker(p.x() + 0.8, p.y() + 0.8, 0.2);
        r = c ? 30 : 235;
        g = c ? 60 : 220;
        b = c ? 140 : 60;
      } else {
        r = 200;
        g = 190;
        b = 170;
      }
      break;
    }
    case 3: {  // left wall: vertical colour stripes
      const double s = 0.5 + 0.5 * std::sin(p.z() * 6.0);
      r = 90 + 120 * s;
      g = 160;
      b = 200 - 100 * s;
      break;
    }
    case 4: {  // right wall: horizontal bands
      const int band = int(std::floor((p.y() + 1.5) / 0.3)) & 3;
      const double c[4][3] = {{180, 70, 60}, {220, 200, 120}, {80, 140, 90}, {210, 210, 210}};
      r = c[band][0];
      g = c[band][1];
      b = c[band][2];
      break;
    }
    case 5: {  // crate: a fine checker on each face
      const int c = std::abs(n.x()) > 0.5   ? checker(p.y(), p.z(), 0.1)
                    : std::abs(n.y()) > 0.5 ? checker(p.x(), p.z(), 0.1)
                                            : checker(p.x(), p.y(), 0.1);
      r = c ? 200 : 120;
      g = c ? 140 : 80;
      b = c ? 60 : 30;
      break;
    }
    case 6: {  // ball: red and white segments
      const double a = std::atan2(p.z() - 1.5, p.x() - 0.45);
      const bool red = (int(std::floor(a / (M_PI / 4))) & 1) != 0;
      r = red ? 210 : 240;
      g = red ? 40 : 240;
      b = red ? 40 : 235;
      break;
    }
    default:
      break;
  }
  // Soft lighting from above-front so the image looks like a photograph, not flat paint.
  const double light = 0.75 + 0.25 * std::max(0.0, n.dot(Eigen::Vector3d(0.2, -0.8, -0.5).normalized()));
  return cv::Vec3b(cv::saturate_cast<uchar>(b * light), cv::saturate_cast<uchar>(g * light),
                   cv::saturate_cast<uchar>(r * light));  // BGR for imwrite
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: make_sample OUT_DIR [frames]\n");
    return 2;
  }
  namespace fs = std::filesystem;
  const fs::path out = argv[1];
  const int frames = argc > 2 ? std::max(1, std::atoi(argv[2])) : 3;
  fs::create_directories(out / "rgb");
  fs::create_directories(out / "depth");
  const int W = 640, H = 480;
  const double fx = 525, fy = 525, cx = 319.5, cy = 239.5;
  std::mt19937 rng(20130917);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> uni(0.0, 1.0);

  std::ofstream rgb_txt(out / "rgb.txt"), depth_txt(out / "depth.txt"), gt_txt(out / "groundtruth.txt");
  rgb_txt << "# color images\n# rgbdcast built-in sample (assets/make_sample.cpp)\n# timestamp filename\n";
  depth_txt << "# depth maps\n# rgbdcast built-in sample (assets/make_sample.cpp)\n# timestamp filename\n";
  gt_txt << "# ground truth trajectory (camera to world)\n# timestamp tx ty tz qx qy qz qw\n";

  for (int f = 0; f < frames; ++f) {
    const double t = 1000.0 + f / 30.0;
    // The camera drifts right and turns slightly left, like a robot creeping forward.
    Eigen::Matrix3d R = Eigen::AngleAxisd(-0.01 * f, Eigen::Vector3d::UnitY()).toRotationMatrix() *
                        Eigen::AngleAxisd(-0.30, Eigen::Vector3d::UnitX()).toRotationMatrix();
    Eigen::Vector3d C(-0.1 + 0.01 * f, -0.45, 0.0 + 0.005 * f);
    cv::Mat rgb(H, W, CV_8UC3), depth(H, W, CV_16UC1, cv::Scalar(0));
    cv::Mat zbuf(H, W, CV_64F);
    for (int v = 0; v < H; ++v) {
      for (int u = 0; u < W; ++u) {
        const Eigen::Vector3d dc((u - cx) / fx, (v - cy) / fy, 1.0);
        const Eigen::Vector3d d = (R * dc).normalized();
        const Hit h = trace(C, d);
        const Eigen::Vector3d p = C + h.t * d;
        rgb.at<cv::Vec3b>(v, u) = shade(h.material, p, h.n);
        const double z = (R.transpose() * (p - C)).z();
        zbuf.at<double>(v, u) = z;
        const double cos_incidence = std::abs(h.n.dot(d));
        if (z > 4.5 || z < 0.5 || cos_incidence < 0.15) continue;  // out of range or grazing: no reading
        // Noise on disparity: sigma_z = 1.425e-3 z^2, then quantise to the sensor's 1/8-pixel disparity steps.
        double zn = z + 1.425e-3 * z * z * gauss(rng);
        const double disparity = std::round(8.0 * 575.0 * 0.075 / zn) / 8.0;
        zn = 575.0 * 0.075 / disparity;
        if (uni(rng) < 0.01) continue;  // speckle dropouts
        depth.at<uint16_t>(v, u) = static_cast<uint16_t>(std::lround(zn * 5000.0));
      }
    }
    // The projector sits 7.5 cm to the right: just right of a near-to-far edge the far surface is in shadow.
    for (int v = 0; v < H; ++v)
      for (int u = 1; u < W; ++u) {
        const double jump = zbuf.at<double>(v, u) - zbuf.at<double>(v, u - 1);
        if (jump > 0.08) {
          const int width = std::min(
              W - u, int(std::lround(575.0 * 0.075 * jump / (zbuf.at<double>(v, u) * zbuf.at<double>(v, u - 1)))) + 1);
          for (int k = 0; k < width; ++k) depth.at<uint16_t>(v, u + k) = 0;
        }
      }
    char name[64];
    std::snprintf(name, sizeof name, "%.6f.png", t);
    cv::imwrite((out / "rgb" / name).string(), rgb);
    cv::imwrite((out / "depth" / name).string(), depth);
    rgb_txt << std::fixed << t << " rgb/" << name << "\n";
    depth_txt << std::fixed << t << " depth/" << name << "\n";
    const Eigen::Quaterniond q(R);
    gt_txt << std::fixed << t << " " << C.x() << " " << C.y() << " " << C.z() << " " << q.x() << " " << q.y() << " "
           << q.z() << " " << q.w() << "\n";
  }
  std::printf("make_sample: wrote %d frames to %s\n", frames, out.string().c_str());
  return 0;
}
