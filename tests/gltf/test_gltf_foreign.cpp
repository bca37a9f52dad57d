// An ordinary textured-mesh GLB as other tools write it (not by rgbdcast): interleaved float POSITION/TEXCOORD_0,
// 8-bit indices, a PNG texture, TRS node transforms under a parent with a matrix, a second non-indexed primitive
// with float VEC4 COLOR_0. It passes the Khronos validator and our reader brings it into the scene convention.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "gltf/glb_container.h"
#include "gltf/gltf_io.h"
#include "tests/common/test_data.h"
#include "tests/common/gltf_validator.h"

using namespace rgbdcast;
using nlohmann::json;

namespace {

template <class T>
void append(std::vector<std::uint8_t>& bin, const std::vector<T>& v) {
  const auto* p = reinterpret_cast<const std::uint8_t*>(v.data());
  bin.insert(bin.end(), p, p + v.size() * sizeof(T));
  while (bin.size() % 4) bin.push_back(0);
}

}  // namespace

TEST(GltfForeign, ReadsAnOrdinaryTexturedGlb) {
  // Quad in its own frame (y up, as glTF content usually is).
  const std::vector<float> interleaved = {0, 0, 0, 0, 1, 1, 0, 0, 1, 1, 1, 1, 0, 1, 0, 0, 1, 0, 0, 0};
  const std::vector<std::uint8_t> indices = {0, 1, 2, 0, 2, 3};
  cv::Mat tex(4, 8, CV_8UC3);
  cv::randu(tex, 0, 255);
  std::vector<std::uint8_t> png;
  ASSERT_TRUE(cv::imencode(".png", tex, png));  // BGR in OpenCV
  const std::vector<float> tri_pos = {0, 0, -1, 1, 0, -1, 0, 1, -1};
  const std::vector<float> tri_col = {1, 0, 0, 1, 0, 1, 0, 1, 0, 0, 1, 1};

  std::vector<std::uint8_t> bin;
  append(bin, interleaved);
  const size_t off_idx = bin.size();
  append(bin, indices);
  const size_t off_png = bin.size();
  append(bin, png);
  const size_t off_tri = bin.size();
  append(bin, tri_pos);
  const size_t off_col = bin.size();
  append(bin, tri_col);

  json doc = {
      {"asset", {{"version", "2.0"}, {"generator", "hand-written test GLB"}}},
      {"scene", 0},
      {"scenes", {{{"nodes", {0}}}}},
      {"nodes",
       {{{"name", "parent"}, {"matrix", {2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 1, 2, 3, 1}}, {"children", {1}}},
        {{"name", "quad"},
         {"mesh", 0},
         {"translation", {0.5, 0, -4}},
         {"rotation", {0, 0.7071067811865476, 0, 0.7071067811865476}},
         {"scale", {1, 1, 1}}}}},
      {"meshes",
       {{{"primitives",
          {{{"attributes", {{"POSITION", 0}, {"TEXCOORD_0", 1}}}, {"indices", 2}, {"material", 0}},
           {{"attributes", {{"POSITION", 3}, {"COLOR_0", 4}}}}}}}}},
      {"materials", {{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}}}},
      {"textures", {{{"source", 0}}}},
      {"images", {{{"bufferView", 2}, {"mimeType", "image/png"}}}},
      {"accessors",
       {{{"bufferView", 0},
         {"componentType", 5126},
         {"count", 4},
         {"type", "VEC3"},
         {"min", {0, 0, 0}},
         {"max", {1, 1, 0}}},
        {{"bufferView", 0}, {"byteOffset", 12}, {"componentType", 5126}, {"count", 4}, {"type", "VEC2"}},
        {{"bufferView", 1}, {"componentType", 5121}, {"count", 6}, {"type", "SCALAR"}},
        {{"bufferView", 3},
         {"componentType", 5126},
         {"count", 3},
         {"type", "VEC3"},
         {"min", {0, 0, -1}},
         {"max", {1, 1, -1}}},
        {{"bufferView", 4}, {"componentType", 5126}, {"count", 3}, {"type", "VEC4"}}}},
      {"bufferViews",
       {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 80}, {"byteStride", 20}, {"target", 34962}},
        {{"buffer", 0}, {"byteOffset", off_idx}, {"byteLength", 6}, {"target", 34963}},
        {{"buffer", 0}, {"byteOffset", off_png}, {"byteLength", png.size()}},
        {{"buffer", 0}, {"byteOffset", off_tri}, {"byteLength", 36}, {"target", 34962}},
        {{"buffer", 0}, {"byteOffset", off_col}, {"byteLength", 48}, {"target", 34962}}}},
      {"buffers", {{{"byteLength", bin.size()}}}},
  };
  const auto glb = glb::pack_glb(doc.dump(), bin);
  const std::string dir = test::temp_dir("gltf-foreign");
  const std::string path = dir + "/foreign.glb";
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(glb.data()), glb.size());
  EXPECT_GLTF_VALID(path);

  auto scene = read_glb_file(path);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  ASSERT_EQ(scene->nodes.size(), 2u);
  const SceneNode& quad = scene->nodes[0];
  ASSERT_EQ(quad.mesh.positions.size(), 4u);
  EXPECT_EQ(quad.mesh.indices, (std::vector<std::uint32_t>{0, 1, 2, 0, 2, 3}));
  ASSERT_TRUE(quad.mesh.textured());
  EXPECT_EQ(quad.mesh.texture.width, 8);
  EXPECT_EQ(quad.mesh.texture_mime, "image/png");
  // PNG is lossless: the texture is the image, in RGB order.
  const cv::Vec3b bgr = tex.at<cv::Vec3b>(3, 5);
  EXPECT_EQ(quad.mesh.texture.pixel(5, 3)[0], bgr[2]);
  EXPECT_EQ(quad.mesh.texture.pixel(5, 3)[2], bgr[0]);
  EXPECT_FLOAT_EQ(quad.mesh.uvs[0].y(), 1.0f);
  // World placement: glTF world = parent matrix * T R S; scene world = C * glTF world.
  Eigen::Affine3d parent = Eigen::Translation3d(1, 2, 3) * Eigen::Scaling(2.0);
  Eigen::Affine3d child = Eigen::Translation3d(0.5, 0, -4) * Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY());
  const Eigen::Matrix4d expected = camera_to_gltf() * (parent * child).matrix();
  EXPECT_LT((quad.to_world - expected).norm(), 1e-9);
  const SceneNode& tri = scene->nodes[1];
  EXPECT_EQ(tri.mesh.indices, (std::vector<std::uint32_t>{0, 1, 2}));  // non-indexed -> 0 1 2
  ASSERT_EQ(tri.mesh.colors.size(), 3u);
  EXPECT_EQ(tri.mesh.colors[1], (Rgb8{0, 255, 0}));
  std::filesystem::remove_all(dir);
}
