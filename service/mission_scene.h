#pragma once
// A live mission as one Scene: each keyframe GLB (its mesh in its own camera frame, as `rgbdcast reduce`
// writes it) placed in the mission's world frame by the pose the sender gave. The world frame is the scene world of
// scene/camera.h (OpenCV axes); encode_glb's root node turns it into glTF axes, as for `reduce --sequence`, whose
// multi-node writer this shares.
// Node names are "keyframe_<seq>" (a keyframe GLB with several primitives: "keyframe_<seq>", "keyframe_<seq>.1", ...),
// which is what RenderPool::append uses to skip nodes a resident mission already has.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "scene/camera.h"
#include "scene/result.h"
#include "scene/scene.h"
#include "service/mission_store.h"

namespace rgbdcast::service {

inline constexpr double kUnitQuaternionTolerance = 1e-3;

// "tx,ty,tz,qx,qy,qz,qw" (TUM order): 7 finite numbers whose quaternion has norm 1 within kUnitQuaternionTolerance.
// kInvalidArgument otherwise, naming what is wrong. The numbers are kept as given (the idempotency key compares them).
Result<std::array<double, 7>> parse_mission_pose(const std::string& text);
// The camera-to-world matrix of a pose (the quaternion normalised).
Eigen::Matrix4d mission_pose_matrix(const std::array<double, 7>& pose);

// The keyframe scene placed in the world: node transforms and capture cameras premultiplied by the pose, nodes
// renamed as above, capture cameras' frame_index set to seq. kInvalidInput when the keyframe has no capture camera.
Result<Scene> place_keyframe(Scene keyframe, std::int64_t seq, const std::array<double, 7>& pose);
// The placed keyframe's capture camera as stored in MissionKeyframe::camera (service/camera_json.h's form, world
// pose), and back. The reader checks it as camera JSON; the size of the view is the caller's.
nlohmann::json mission_camera_json(const CaptureCamera& camera);
Result<ViewCamera> mission_view_camera(const MissionKeyframe& keyframe, int width, int height);

// One stored keyframe (k.mission, k.seq, k.rev) decoded and placed by its pose. kNotFound when that revision is no
// longer stored, kInternal when it no longer decodes.
Result<Scene> load_placed_keyframe(const MissionStore& store, const MissionKeyframe& k);

// Every keyframe of a mission decoded and placed, in seq order: what a renderer uploads on a cache miss and what
// model.glb encodes. kNotFound for an unknown mission, kInternal when a stored keyframe no longer decodes.
// Each keyframe's current revision; a revision stored meanwhile makes it list the mission again.
Result<Scene> assemble_mission(const MissionStore& store, const std::string& name);
// The same for a listing the caller made (kNotFound when a listed revision is no longer stored).
Result<Scene> assemble_keyframes(const MissionStore& store, const std::string& name,
                                 const std::vector<MissionKeyframe>& keyframes);

}  // namespace rgbdcast::service
