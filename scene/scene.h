#pragma once
// A scene: what one GLB holds. One node per keyframe (its mesh and/or points placed in the world), and the capture
// cameras. This is the only thing the reduction hands to the renderer.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "scene/camera.h"
#include "scene/mesh.h"

namespace rgbdcast {

struct SceneNode {
  std::string name;
  Mesh mesh;                                               // may be empty
  PointCloud points;                                       // may be empty
  Eigen::Matrix4d to_world = Eigen::Matrix4d::Identity();  // node frame -> world frame
};

struct Scene {
  std::vector<SceneNode> nodes;
  std::vector<CaptureCamera> cameras;  // cameras[0] is the reference view ("capture" pose)
  std::string extras_json;             // capture metadata carried through glTF extras (JSON text), may be empty

  size_t triangle_count() const {
    size_t n = 0;
    for (const auto& node : nodes) n += node.mesh.triangle_count();
    return n;
  }
  size_t vertex_count() const {
    size_t n = 0;
    for (const auto& node : nodes) n += node.mesh.positions.size();
    return n;
  }
};

}  // namespace rgbdcast
