#include "service/scene_ingest.h"

#include <chrono>
#include <limits>

#include "base/stopwatch.h"
#include "gltf/gltf_io.h"

namespace rgbdcast::service {

nlohmann::json scene_stats(const Scene& scene, size_t glb_bytes) {
  size_t points = 0;
  for (const auto& node : scene.nodes) points += node.points.size();
  nlohmann::json stats = {{"nodes", scene.nodes.size()},
                          {"vertices", scene.vertex_count()},
                          {"triangles", scene.triangle_count()},
                          {"points", points > 0 ? points : scene.vertex_count()},
                          {"bytes", glb_bytes}};
  // Bounds in the world frame (the first capture camera's), for clients that orbit around the scene.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const auto& node : scene.nodes) {
    const Eigen::Matrix3d r = node.to_world.block<3, 3>(0, 0);
    const Eigen::Vector3d t = node.to_world.block<3, 1>(0, 3);
    for (const auto* list : {&node.mesh.positions, &node.points.positions})
      for (const auto& p : *list) {
        const Eigen::Vector3d w = r * p.cast<double>() + t;
        if (!w.allFinite()) continue;
        lo = lo.cwiseMin(w);
        hi = hi.cwiseMax(w);
      }
  }
  if (lo.allFinite() && hi.allFinite())
    stats["bounds"] = {{"min", {lo.x(), lo.y(), lo.z()}}, {"max", {hi.x(), hi.y(), hi.z()}}};
  else
    stats["bounds"] = nullptr;
  if (!scene.cameras.empty()) {
    const CaptureCamera& c = scene.cameras.front();
    std::vector<double> pose;
    for (int r = 0; r < 4; ++r)
      for (int col = 0; col < 4; ++col) pose.push_back(c.camera_to_world(r, col));
    stats["capture_camera"] = {{"fx", c.intrinsics.fx},       {"fy", c.intrinsics.fy},
                               {"cx", c.intrinsics.cx},       {"cy", c.intrinsics.cy},
                               {"width", c.intrinsics.width}, {"height", c.intrinsics.height},
                               {"camera_to_world", pose},     {"timestamp", c.timestamp},
                               {"source", c.source},          {"frame_index", c.frame_index}};
  } else {
    stats["capture_camera"] = nullptr;
  }
  // Stage timings travel in the GLB's extras when rgbdcast wrote it ({"rgbdcast": {"stages": [...]}}).
  stats["stages"] = nlohmann::json::array();
  if (!scene.extras_json.empty()) {
    auto extras = nlohmann::json::parse(scene.extras_json, nullptr, false);
    if (extras.is_object() && extras.contains("rgbdcast")) extras = extras["rgbdcast"];
    if (extras.is_object() && extras.contains("stages") && extras["stages"].is_array())
      stats["stages"] = extras["stages"];
    // What the reduction chose ({"preset", "texture", "budget"?}, pipeline/frame_scene.h choices_json).
    if (extras.is_object() && extras.contains("reduction") && extras["reduction"].is_object())
      stats["reduction"] = extras["reduction"];
  }
  return stats;
}

Result<Scene> decode_client_glb(const std::vector<std::uint8_t>& glb) {
  if (glb.empty()) return make_error(ErrorCode::kInvalidInput, "empty body: expected a GLB");
  auto scene = decode_glb(glb.data(), glb.size());
  if (!scene) return make_error(ErrorCode::kInvalidInput, "not a valid GLB: " + scene.error().message);
  if (scene->triangle_count() == 0 && scene->vertex_count() == 0) {
    size_t points = 0;
    for (const auto& node : scene->nodes) points += node.points.size();
    if (points == 0) return make_error(ErrorCode::kEmpty, "the GLB holds no triangles and no points");
  }
  return scene;
}

Result<IngestedScene> ingest_glb(std::vector<std::uint8_t> glb) {
  const auto t0 = std::chrono::steady_clock::now();
  auto scene = decode_client_glb(glb);
  if (!scene) return scene.error();
  const double decode_ms = ms_since(t0);
  IngestedScene out;
  out.stats = scene_stats(*scene, glb.size());
  out.stats["source"] = "glb";
  out.stats["ingest_ms"] = decode_ms;
  out.glb = std::move(glb);
  return out;
}

}  // namespace rgbdcast::service
