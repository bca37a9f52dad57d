// The camera-to-glTF axis convention, checked on the written JSON with an independent transform walk: a point in
// front of the capture camera is in front of the glTF camera node (along its -z), and up in the image is +y.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "gltf/glb_container.h"
#include "gltf/gltf_io.h"
#include "tests/gltf/sample_scenes.h"

using namespace rgbdcast;

namespace {

Eigen::Matrix4d local(const nlohmann::json& node) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  if (node.contains("matrix"))
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r) m(r, c) = node["matrix"][c * 4 + r].get<double>();
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity(), s = Eigen::Matrix4d::Identity();
  if (node.contains("translation"))
    for (int k = 0; k < 3; ++k) t(k, 3) = node["translation"][k].get<double>();
  if (node.contains("scale"))
    for (int k = 0; k < 3; ++k) s(k, k) = node["scale"][k].get<double>();
  return m * t * s;
}

// glTF world matrix of every node (parents first).
std::vector<Eigen::Matrix4d> world_matrices(const nlohmann::json& doc) {
  std::vector<Eigen::Matrix4d> w(doc["nodes"].size(), Eigen::Matrix4d::Identity());
  std::function<void(int, const Eigen::Matrix4d&)> walk = [&](int i, const Eigen::Matrix4d& parent) {
    w[i] = parent * local(doc["nodes"][i]);
    for (const auto& c : doc["nodes"][i].value("children", nlohmann::json::array())) walk(c.get<int>(), w[i]);
  };
  for (const auto& r : doc["scenes"][0]["nodes"]) walk(r.get<int>(), Eigen::Matrix4d::Identity());
  return w;
}

}  // namespace

TEST(GltfAxes, PointAheadOfCaptureCameraIsAlongMinusZOfTheGltfCamera) {
  Scene scene;
  CaptureCamera cam;
  Eigen::Affine3d pose =
      Eigen::Translation3d(0.5, -0.2, 1.0) * Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.3, 1, 0.1).normalized());
  cam.camera_to_world = pose.matrix();
  scene.cameras.push_back(cam);
  // A mesh node whose vertex 0 sits 2 m straight ahead of the camera, vertex 1 above it in the image (-y camera).
  SceneNode n;
  n.mesh.positions = {Eigen::Vector3f(0, 0, 2), Eigen::Vector3f(0, -0.5f, 2), Eigen::Vector3f(0.5f, 0, 2)};
  n.mesh.indices = {0, 1, 2};
  n.mesh.colors = {Rgb8{1, 2, 3}, Rgb8{1, 2, 3}, Rgb8{1, 2, 3}};
  n.to_world = cam.camera_to_world;  // mesh in the camera's frame, placed in the world by the camera pose
  scene.nodes.push_back(n);
  GlbWriteOptions o;
  o.quantize = false;
  auto glb = encode_glb(scene, o);
  ASSERT_TRUE(glb.ok());
  auto chunks = glb::parse_glb(glb->data(), glb->size());
  ASSERT_TRUE(chunks.ok());
  const auto doc = nlohmann::json::parse(chunks->json);
  const auto W = world_matrices(doc);
  int cam_node = -1, mesh_node = -1;
  for (size_t i = 0; i < doc["nodes"].size(); ++i) {
    if (doc["nodes"][i].contains("camera")) cam_node = static_cast<int>(i);
    if (doc["nodes"][i].contains("mesh")) mesh_node = static_cast<int>(i);
  }
  ASSERT_GE(cam_node, 0);
  ASSERT_GE(mesh_node, 0);
  const Eigen::Matrix4d cam_inv = W[cam_node].inverse();
  auto in_cam = [&](const Eigen::Vector3f& p) {
    return (cam_inv * W[mesh_node] * Eigen::Vector4d(p.x(), p.y(), p.z(), 1)).head<3>().eval();
  };
  const Eigen::Vector3d ahead = in_cam(n.mesh.positions[0]);
  EXPECT_NEAR(ahead.x(), 0, 1e-9);
  EXPECT_NEAR(ahead.y(), 0, 1e-9);
  EXPECT_NEAR(ahead.z(), -2.0, 1e-9);  // glTF cameras look along -z
  const Eigen::Vector3d above = in_cam(n.mesh.positions[1]);
  EXPECT_NEAR(above.y(), 0.5, 1e-9);  // up in the image is +y in glTF
  const Eigen::Vector3d right = in_cam(n.mesh.positions[2]);
  EXPECT_NEAR(right.x(), 0.5, 1e-9);  // x right in both
  // The root carries C = diag(1,-1,-1): scene-world up (-y) becomes glTF +y.
  EXPECT_EQ(doc["nodes"][doc["scenes"][0]["nodes"][0].get<int>()]["name"], "rgbdcast_world");
  // yfov from fy and the image height.
  EXPECT_NEAR(doc["cameras"][0]["perspective"]["yfov"].get<double>(), 2 * std::atan(240.0 / 525.0), 1e-12);

  // Our reader maps it back into the scene convention.
  auto back = decode_glb(glb->data(), glb->size());
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_LT((back->cameras[0].camera_to_world - cam.camera_to_world).norm(), 1e-9);
  EXPECT_LT((back->nodes[0].to_world - n.to_world).norm(), 1e-9);
}
