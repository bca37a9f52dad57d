#include "keyframes/trajectory_io.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

#include "base/atomic_file.h"

namespace rgbdcast {

namespace fs = std::filesystem;

Eigen::Matrix4d pose_from_tum(double tx, double ty, double tz, double qx, double qy, double qz, double qw) {
  Eigen::Quaterniond q(qw, qx, qy, qz);
  q.normalize();
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  t.topLeftCorner<3, 3>() = q.toRotationMatrix();
  t.topRightCorner<3, 1>() = Eigen::Vector3d(tx, ty, tz);
  return t;
}

namespace {

Result<std::ifstream> open_text(const std::string& path, const char* what) {
  if (!fs::exists(path)) return make_error(ErrorCode::kNotFound, std::string(what) + " not found: " + path);
  std::ifstream in(path);
  if (!in) return make_error(ErrorCode::kIo, std::string("cannot read ") + what + ": " + path);
  return in;
}

// Numbers of a line, or empty for a blank/comment line; ok=false when a token is not a finite number.
std::vector<double> numbers(const std::string& line, bool* ok) {
  *ok = true;
  std::vector<double> v;
  const size_t first = line.find_first_not_of(" \t\r");
  if (first == std::string::npos || line[first] == '#') return v;
  std::istringstream ss(line);
  std::string tok;
  while (ss >> tok) {
    char* end = nullptr;
    const double x = std::strtod(tok.c_str(), &end);
    if (end == tok.c_str() || *end != '\0' || !std::isfinite(x)) {
      *ok = false;
      return {};
    }
    v.push_back(x);
  }
  return v;
}

bool valid_quaternion(double qx, double qy, double qz, double qw) {
  const double n = std::sqrt(qx * qx + qy * qy + qz * qz + qw * qw);
  return n > 0.5 && n < 1.5;
}

}  // namespace

namespace {

Result<Trajectory> parse_tum(std::istream& in, const std::string& path) {
  Trajectory tr;
  std::string line;
  int line_no = 0;
  bool ordered = true;
  while (std::getline(in, line)) {
    ++line_no;
    bool ok = true;
    const std::vector<double> v = numbers(line, &ok);
    if (ok && v.empty()) continue;
    if (!ok || v.size() != 8 || !valid_quaternion(v[4], v[5], v[6], v[7])) {
      tr.warnings.push_back(path + ":" + std::to_string(line_no) + ": not 't tx ty tz qx qy qz qw', skipped");
      continue;
    }
    if (!tr.poses.empty() && v[0] < tr.poses.back().timestamp) ordered = false;
    tr.poses.push_back({v[0], -1, pose_from_tum(v[1], v[2], v[3], v[4], v[5], v[6], v[7])});
  }
  if (tr.poses.empty()) return make_error(ErrorCode::kInvalidInput, "no pose line in " + path);
  if (!ordered) {
    tr.warnings.push_back(path + ": timestamps out of order, sorted by time");
    std::stable_sort(tr.poses.begin(), tr.poses.end(),
                     [](const StampedPose& a, const StampedPose& b) { return a.timestamp < b.timestamp; });
  }
  const size_t before = tr.poses.size();
  tr.poses.erase(std::unique(tr.poses.begin(), tr.poses.end(),
                             [](const StampedPose& a, const StampedPose& b) { return a.timestamp == b.timestamp; }),
                 tr.poses.end());
  if (tr.poses.size() != before)
    tr.warnings.push_back(path + ": " + std::to_string(before - tr.poses.size()) + " duplicate timestamps dropped");
  return tr;
}

Result<Trajectory> parse_redwood(std::istream& in, const std::string& path) {
  Trajectory tr;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    bool ok = true;
    std::vector<double> head = numbers(line, &ok);
    if (ok && head.empty()) continue;
    if (!ok || head.size() != 3)
      return make_error(ErrorCode::kInvalidInput, path + ":" + std::to_string(line_no) + ": expected 'i j n' header");
    if (!(head[0] >= 0 && head[0] <= 2147483647.0 && head[0] == std::floor(head[0])))
      return make_error(ErrorCode::kInvalidInput,
                        path + ":" + std::to_string(line_no) + ": frame index is not a non-negative integer");
    StampedPose p;
    p.index = static_cast<int>(head[0]);
    for (int r = 0; r < 4; ++r) {
      if (!std::getline(in, line))
        return make_error(ErrorCode::kInvalidInput, path + ": truncated matrix after line " + std::to_string(line_no));
      ++line_no;
      const std::vector<double> row = numbers(line, &ok);
      if (!ok || row.size() != 4)
        return make_error(ErrorCode::kInvalidInput, path + ":" + std::to_string(line_no) + ": expected 4 numbers");
      for (int c = 0; c < 4; ++c) p.camera_to_world(r, c) = row[static_cast<size_t>(c)];
    }
    const Eigen::Matrix3d rot = p.camera_to_world.topLeftCorner<3, 3>();
    if ((rot.transpose() * rot - Eigen::Matrix3d::Identity()).norm() > 1e-3 || rot.determinant() < 0)
      tr.warnings.push_back(path + ":" + std::to_string(line_no) + ": frame " + std::to_string(p.index) +
                            " is not a rotation, kept as is");
    tr.poses.push_back(p);
  }
  if (tr.poses.empty()) return make_error(ErrorCode::kInvalidInput, "no pose in " + path);
  return tr;
}

Result<Trajectory> parse_icl(std::istream& in, const std::string& path, bool icl_to_rgbdcast) {
  Trajectory tr;
  std::string line;
  int line_no = 0, frame = 0;
  Eigen::Matrix4d s = Eigen::Matrix4d::Identity();
  s(1, 1) = -1.0;
  while (std::getline(in, line)) {
    ++line_no;
    bool ok = true;
    const std::vector<double> v = numbers(line, &ok);
    if (ok && v.empty()) continue;
    if (!ok || v.size() != 7 || !valid_quaternion(v[3], v[4], v[5], v[6])) {
      tr.warnings.push_back(path + ":" + std::to_string(line_no) + ": not 'tx ty tz qx qy qz qw', frame " +
                            std::to_string(frame) + " has no pose");
      ++frame;
      continue;
    }
    StampedPose p;
    p.index = frame++;
    p.camera_to_world = pose_from_tum(v[0], v[1], v[2], v[3], v[4], v[5], v[6]);
    if (icl_to_rgbdcast) p.camera_to_world = s * p.camera_to_world * s;
    tr.poses.push_back(p);
  }
  if (tr.poses.empty()) return make_error(ErrorCode::kInvalidInput, "no pose line in " + path);
  return tr;
}

}  // namespace

Result<Trajectory> read_tum_trajectory(const std::string& path) {
  Result<std::ifstream> in = open_text(path, "ground-truth file");
  if (!in) return in.error();
  return parse_tum(*in, path);
}

Result<Trajectory> read_redwood_log(const std::string& path) {
  Result<std::ifstream> in = open_text(path, "trajectory log");
  if (!in) return in.error();
  return parse_redwood(*in, path);
}

Result<Trajectory> read_icl_pose_txt(const std::string& path, bool icl_to_rgbdcast) {
  Result<std::ifstream> in = open_text(path, "pose file");
  if (!in) return in.error();
  return parse_icl(*in, path, icl_to_rgbdcast);
}

Result<Trajectory> parse_trajectory(std::string_view text, TrajectoryFormat format, const std::string& name) {
  std::istringstream in{std::string(text)};
  switch (format) {
    case TrajectoryFormat::kTum:
      return parse_tum(in, name);
    case TrajectoryFormat::kRedwood:
      return parse_redwood(in, name);
    case TrajectoryFormat::kIcl:
      return parse_icl(in, name, true);
  }
  return make_error(ErrorCode::kInvalidArgument, "unknown trajectory format");
}

Result<Trajectory> read_trajectory(const std::string& path) {
  if (fs::path(path).extension() == ".log") return read_redwood_log(path);
  Result<std::ifstream> in = open_text(path, "trajectory file");
  if (!in) return in.error();
  std::string line;
  while (std::getline(*in, line)) {
    bool ok = true;
    const std::vector<double> v = numbers(line, &ok);
    if (!ok || v.empty()) continue;
    if (v.size() == 7) return read_icl_pose_txt(path);
    if (v.size() == 8) return read_tum_trajectory(path);
    break;
  }
  return make_error(ErrorCode::kInvalidInput, "unknown trajectory format (not .log, 7 or 8 numbers a line): " + path);
}

Status write_tum_trajectory(const std::string& path, const Trajectory& tr) {
  std::ostringstream out;
  out << "# timestamp tx ty tz qx qy qz qw (camera to world, rgbdcast camera: x right, y down, z forward)\n";
  out << std::fixed;
  for (const StampedPose& p : tr.poses) {
    const Eigen::Quaterniond q(Eigen::Matrix3d(p.camera_to_world.topLeftCorner<3, 3>()));
    const Eigen::Vector3d t = p.camera_to_world.topRightCorner<3, 1>();
    out << std::setprecision(6) << p.timestamp << std::setprecision(7) << ' ' << t.x() << ' ' << t.y() << ' ' << t.z()
        << ' ' << q.x() << ' ' << q.y() << ' ' << q.z() << ' ' << q.w() << '\n';
  }
  return write_file_atomically(path, out.str());
}

Status write_redwood_log(const std::string& path, const Trajectory& tr) {
  std::ostringstream out;
  out << std::setprecision(17);
  for (size_t i = 0; i < tr.poses.size(); ++i) {
    const int index = tr.poses[i].index >= 0 ? tr.poses[i].index : static_cast<int>(i);
    out << index << ' ' << index << ' ' << index + 1 << '\n';
    for (int r = 0; r < 4; ++r)
      out << tr.poses[i].camera_to_world(r, 0) << ' ' << tr.poses[i].camera_to_world(r, 1) << ' '
          << tr.poses[i].camera_to_world(r, 2) << ' ' << tr.poses[i].camera_to_world(r, 3) << '\n';
  }
  return write_file_atomically(path, out.str());
}

const StampedPose* nearest_pose(const Trajectory& tr, double t, double max_difference_s) {
  auto it = std::lower_bound(tr.poses.begin(), tr.poses.end(), t,
                             [](const StampedPose& p, double x) { return p.timestamp < x; });
  const StampedPose* best = nullptr;
  double best_dt = max_difference_s;
  for (auto c : {it, it == tr.poses.begin() ? tr.poses.end() : std::prev(it)}) {
    if (c == tr.poses.end()) continue;
    const double dt = std::abs(c->timestamp - t);
    if (dt <= best_dt) {
      best_dt = dt;
      best = &*c;
    }
  }
  return best;
}

const StampedPose* pose_with_index(const Trajectory& tr, int index) {
  for (const StampedPose& p : tr.poses)
    if (p.index == index) return &p;
  return nullptr;
}

}  // namespace rgbdcast
