#include "tests/service/mission_keyframes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <Eigen/Geometry>

#include "tests/common/run_command.h"
#include "tests/common/test_data.h"
#include "tests/service/server_process.h"  // read_file

namespace rgbdcast::test {
namespace {

struct Stamped {
  double t = 0;
  std::vector<double> v;
};

std::vector<Stamped> read_table(const std::string& path, size_t numbers) {
  std::vector<Stamped> out;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    Stamped r;
    s >> r.t;
    for (size_t i = 0; i < numbers; ++i) {
      double x = 0;
      s >> x;
      r.v.push_back(x);
    }
    if (s) out.push_back(r);
  }
  return out;
}

Eigen::Matrix4d pose_of(const std::vector<double>& v) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = Eigen::Quaterniond(v[6], v[3], v[4], v[5]).normalized().toRotationMatrix();
  m.topRightCorner<3, 1>() = Eigen::Vector3d(v[0], v[1], v[2]);
  return m;
}

}  // namespace

std::string mission_keyframe_cache() {
  const char* shared = std::getenv("RGBDCAST_MISSION_KEYFRAMES_DIR");
  if (shared && *shared) {
    std::filesystem::create_directories(shared);
    return shared;
  }
  // Built once per test program and removed when it exits.
  struct Cache {
    std::string dir = temp_dir("mission-keyframes");
    ~Cache() { remove_tree_quietly(dir); }
  };
  static const Cache cache;
  return cache.dir;
}

std::vector<MissionKeyframeFile> mission_keyframes(const std::vector<int>& frames, std::string* error) {
  std::vector<MissionKeyframeFile> out;
  const std::string root = data_path(kMissionExcerpt);
  const auto rgb = read_table(root + "/rgb.txt", 0);
  const auto gt = read_table(root + "/groundtruth.txt", 7);
  if (rgb.empty() || gt.empty()) {
    *error = "cannot read rgb.txt / groundtruth.txt of " + root;
    return {};
  }
  auto nearest = [&](double t) {
    const Stamped* best = &gt.front();
    for (const auto& g : gt)
      if (std::abs(g.t - t) < std::abs(best->t - t)) best = &g;
    return pose_of(best->v);
  };
  const std::string cache = mission_keyframe_cache();
  const Eigen::Matrix4d world_from_first_inv = nearest(rgb.at(static_cast<size_t>(frames.front())).t).inverse();
  for (int f : frames) {
    if (f < 0 || static_cast<size_t>(f) >= rgb.size()) {
      *error = "no frame " + std::to_string(f);
      return {};
    }
    const std::string glb = cache + "/kf" + std::to_string(f) + ".glb";
    if (!std::filesystem::exists(glb)) {
      const auto r = run_command(rgbdcast_binary() + " reduce --input " + root + " --frame " + std::to_string(f) +
                                 " --preset realtime --budget-kb 12 --out " + glb);
      if (r.exit_code != 0) {
        *error = "rgbdcast reduce failed on frame " + std::to_string(f) + ": " + r.err + r.out;
        return {};
      }
    }
    MissionKeyframeFile k;
    k.frame = f;
    k.glb = read_file(glb);
    k.captured = rgb[static_cast<size_t>(f)].t;
    const Eigen::Matrix4d p = world_from_first_inv * nearest(k.captured);
    const Eigen::Quaterniond q(Eigen::Matrix3d(p.topLeftCorner<3, 3>()));
    char buf[256];
    std::snprintf(buf, sizeof buf, "%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g", p(0, 3), p(1, 3), p(2, 3), q.x(), q.y(), q.z(),
                  q.w());
    k.pose = buf;
    out.push_back(std::move(k));
  }
  return out;
}

const std::vector<MissionKeyframeFile>& four_mission_keyframes() {
  static std::string error;
  static const auto k = mission_keyframes({0, 40, 80, 119}, &error);
  if (k.empty()) ADD_FAILURE() << error;
  return k;
}

}  // namespace rgbdcast::test
