#include "service/mission_scene.h"

#include <cmath>
#include <sstream>

#include <Eigen/Geometry>

#include "gltf/gltf_io.h"
#include "scene/error_text.h"
#include "service/camera_json.h"
#include "service/view_params.h"  // parse_finite_double

namespace rgbdcast::service {

Result<std::array<double, 7>> parse_mission_pose(const std::string& text) {
  auto bad = [](const std::string& why) {
    return make_error(ErrorCode::kInvalidArgument, "pose: " + why + " (expected tx,ty,tz,qx,qy,qz,qw)");
  };
  if (text.empty()) return bad("missing");
  if (text.size() > 512) return bad("too long");
  std::array<double, 7> pose{};
  size_t start = 0, n = 0;
  for (;;) {
    const size_t comma = text.find(',', start);
    const std::string part = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    if (n == 7) return bad("more than 7 numbers");
    auto v = parse_finite_double("pose", part);
    if (!v) return bad(single_quoted_for_error(part) + " is not a finite number");
    pose[n++] = *v;
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (n != 7) return bad(std::to_string(n) + " numbers");
  const double norm = std::sqrt(pose[3] * pose[3] + pose[4] * pose[4] + pose[5] * pose[5] + pose[6] * pose[6]);
  if (std::abs(norm - 1.0) > kUnitQuaternionTolerance) {
    std::ostringstream why;
    why << "the quaternion's norm is " << norm << ", not 1 within " << kUnitQuaternionTolerance;
    return bad(why.str());
  }
  for (int i = 0; i < 3; ++i)
    if (std::abs(pose[i]) > 1e6) return bad("translation beyond 1e6 m");
  return pose;
}

Eigen::Matrix4d mission_pose_matrix(const std::array<double, 7>& p) {
  Eigen::Quaterniond q(p[6], p[3], p[4], p[5]);
  q.normalize();
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = q.toRotationMatrix();
  m.topRightCorner<3, 1>() = Eigen::Vector3d(p[0], p[1], p[2]);
  return m;
}

Result<Scene> place_keyframe(Scene keyframe, std::int64_t seq, const std::array<double, 7>& pose) {
  if (keyframe.cameras.empty())
    return make_error(ErrorCode::kInvalidInput, "the keyframe GLB has no capture camera (rgbdcast reduce writes one)");
  const Eigen::Matrix4d world_from_keyframe = mission_pose_matrix(pose);
  const std::string name = "keyframe_" + std::to_string(seq);
  for (size_t i = 0; i < keyframe.nodes.size(); ++i) {
    SceneNode& node = keyframe.nodes[i];
    node.to_world = world_from_keyframe * node.to_world;
    node.name = i == 0 ? name : name + "." + std::to_string(i);
  }
  for (CaptureCamera& cam : keyframe.cameras) {
    cam.camera_to_world = world_from_keyframe * cam.camera_to_world;
    cam.frame_index = static_cast<int>(seq);
  }
  keyframe.cameras.resize(1);  // one capture camera per keyframe
  keyframe.extras_json.clear();
  return keyframe;
}

nlohmann::json mission_camera_json(const CaptureCamera& camera) {
  return nlohmann::json::parse(camera_json(ViewCamera::from_capture(camera)));
}

Result<ViewCamera> mission_view_camera(const MissionKeyframe& keyframe, int width, int height) {
  auto native = parse_camera_json(keyframe.camera.dump(), kMaxImageSize);
  if (!native)
    return make_error(ErrorCode::kInternal,
                      "stored camera of keyframe " + std::to_string(keyframe.seq) + ": " + native.error().message);
  CaptureCamera cam;
  cam.intrinsics.fx = native->fx;
  cam.intrinsics.fy = native->fy;
  cam.intrinsics.cx = native->cx;
  cam.intrinsics.cy = native->cy;
  cam.intrinsics.width = native->width;
  cam.intrinsics.height = native->height;
  cam.camera_to_world = native->camera_to_world;
  return ViewCamera::from_capture(cam, width, height);
}

Result<Scene> assemble_mission(const MissionStore& store, const std::string& name) {
  // A revision stored between the listing and the read removes the GLB that was listed: list again (a few times).
  for (int attempt = 0;; ++attempt) {
    auto keyframes = store.keyframes(name);
    if (!keyframes) return make_error(ErrorCode::kNotFound, "no mission " + name);
    auto scene = assemble_keyframes(store, name, *keyframes);
    if (scene || scene.error().code != ErrorCode::kNotFound || attempt == 3) return scene;
  }
}

Result<Scene> load_placed_keyframe(const MissionStore& store, const MissionKeyframe& k) {
  auto bytes = store.read_glb(k.mission, k.seq, k.rev);
  if (!bytes) return bytes.error();
  auto decoded = decode_glb(bytes->data(), bytes->size());
  if (!decoded)
    return make_error(ErrorCode::kInternal, "stored keyframe " + std::to_string(k.seq) + " of mission " + k.mission +
                                                " no longer decodes: " + decoded.error().message);
  return place_keyframe(std::move(*decoded), k.seq, k.pose);
}

Result<Scene> assemble_keyframes(const MissionStore& store, const std::string& name,
                                 const std::vector<MissionKeyframe>& keyframes) {
  Scene mission;
  for (MissionKeyframe k : keyframes) {
    k.mission = name;
    auto placed = load_placed_keyframe(store, k);
    if (!placed) return placed.error();
    for (auto& node : placed->nodes) mission.nodes.push_back(std::move(node));
    for (auto& cam : placed->cameras) mission.cameras.push_back(std::move(cam));
  }
  nlohmann::json extras = {{"rgbdcast", {{"mission", name}, {"keyframes", keyframes.size()}}}};
  mission.extras_json = extras.dump();
  return mission;
}

}  // namespace rgbdcast::service
