// The compat flavour (gltf/gltf_io.h) on the sample scene (a textured grid, a vertex-coloured mesh with its points, an
// atlas-like mesh, two capture cameras): plain float accessors, JPEG textures, nothing a viewer must decode, and the
// same scene as compact when read back. `rgbdcast convert` on bad input: one line, exit 2, nothing written.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "base/atomic_file.h"
#include "gltf/glb_container.h"
#include "gltf/gltf_io.h"
#include "tests/common/gltf_validator.h"
#include "tests/common/run_command.h"
#include "tests/common/test_data.h"
#include "tests/gltf/sample_scenes.h"

using namespace rgbdcast;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

json json_of(const std::vector<std::uint8_t>& glb) {
  auto chunks = glb::parse_glb(glb.data(), glb.size());
  return chunks ? json::parse(chunks->json, nullptr, false) : json();
}

std::vector<std::uint8_t> png_of(const Image& rgb) {
  cv::Mat view(rgb.height, rgb.width, CV_8UC3, const_cast<std::uint8_t*>(rgb.data.data())), bgr;
  cv::cvtColor(view, bgr, cv::COLOR_RGB2BGR);
  std::vector<std::uint8_t> png;
  cv::imencode(".png", bgr, png);
  return png;
}

// Triangles with the smallest index first (winding kept): meshopt's index codec may rotate a triangle's corners.
std::vector<std::array<std::uint32_t, 3>> triangles_of(const Mesh& m) {
  std::vector<std::array<std::uint32_t, 3>> t;
  for (size_t i = 0; i + 2 < m.indices.size(); i += 3) {
    std::array<std::uint32_t, 3> f = {m.indices[i], m.indices[i + 1], m.indices[i + 2]};
    std::rotate(f.begin(), std::min_element(f.begin(), f.end()), f.end());
    t.push_back(f);
  }
  return t;
}

TEST(GltfFlavors, NamesParseAndUnknownOnesSayWhatIsValid) {
  EXPECT_EQ(parse_glb_flavor("compact").value(), GlbFlavor::kCompact);
  EXPECT_EQ(parse_glb_flavor("compat").value(), GlbFlavor::kCompat);
  EXPECT_STREQ(to_string(GlbFlavor::kCompat), "compat");
  auto bad = parse_glb_flavor("Compat");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(bad.error().message.find("compact"), std::string::npos);
  EXPECT_NE(bad.error().message.find("compat:"), std::string::npos);
}

TEST(GltfFlavors, CompatIsPlainFloatsJpegAndNoRequiredExtension) {
  Scene scene = test::sample_scene();
  // One texture arrives as a PNG (as from a foreign file): compat re-encodes it as JPEG.
  scene.nodes[2].mesh.texture_encoded = png_of(scene.nodes[2].mesh.texture);
  scene.nodes[2].mesh.texture_mime = "image/png";
  GlbWriteOptions compat;
  compat.flavor = GlbFlavor::kCompat;
  compat.meshopt = compat.quantize = true;  // ignored by compat
  GlbStats stats;
  auto glb = encode_glb(scene, compat, &stats);
  ASSERT_TRUE(glb.ok()) << glb.error().message;
  const json doc = json_of(*glb);
  ASSERT_TRUE(doc.is_object());
  EXPECT_FALSE(doc.contains("extensionsRequired")) << doc["extensionsRequired"];
  EXPECT_EQ(doc["extensionsUsed"], json::array({"KHR_materials_unlit"}));
  EXPECT_EQ(doc["buffers"].size(), 1u);
  size_t float_attributes = 0;
  for (const auto& mesh : doc["meshes"])
    for (const auto& prim : mesh["primitives"])
      for (const auto& [name, index] : prim["attributes"].items()) {
        const json& acc = doc["accessors"][index.get<size_t>()];
        EXPECT_EQ(acc["componentType"], 5126) << name;
        EXPECT_FALSE(acc.value("normalized", false)) << name;
        ++float_attributes;
      }
  EXPECT_EQ(float_attributes, 8u);  // grid P+UV, coloured mesh P+C, its points P+C, atlas-like P+UV
  EXPECT_EQ(doc.dump().find("KHR_texture_transform"), std::string::npos);
  EXPECT_EQ(doc.dump().find("KHR_mesh_quantization"), std::string::npos);
  for (const auto& n : doc["nodes"]) EXPECT_FALSE(n.contains("scale")) << n.dump();  // no dequantization nodes
  ASSERT_EQ(doc["images"].size(), 2u);
  for (const auto& img : doc["images"]) EXPECT_EQ(img["mimeType"], "image/jpeg");
  const std::string dir = test::temp_dir("gltf-flavors");
  const std::string path = dir + "/compat.glb";
  ASSERT_TRUE(write_glb_file(scene, path, compat).ok());
  EXPECT_GLTF_VALID(path);

  // Read back: the same scene as the compact file, positions exact (floats) where compact is within its quantum.
  auto compact = encode_glb(scene, {});
  ASSERT_TRUE(compact.ok());
  auto a = decode_glb(compact->data(), compact->size());
  auto b = decode_glb(glb->data(), glb->size());
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_EQ(b->nodes.size(), a->nodes.size());
  ASSERT_EQ(b->cameras.size(), 2u);
  EXPECT_EQ(b->extras_json, a->extras_json);
  for (size_t i = 0; i < a->nodes.size(); ++i) {
    const SceneNode &na = a->nodes[i], &nb = b->nodes[i];
    EXPECT_EQ(triangles_of(nb.mesh), triangles_of(na.mesh)) << i;
    EXPECT_EQ(nb.points.size(), na.points.size()) << i;
    ASSERT_EQ(nb.mesh.positions.size(), na.mesh.positions.size()) << i;
    for (size_t v = 0; v < nb.mesh.positions.size(); ++v) {
      const Eigen::Vector3d pa = (na.to_world * na.mesh.positions[v].cast<double>().homogeneous()).head<3>();
      const Eigen::Vector3d pb = (nb.to_world * nb.mesh.positions[v].cast<double>().homogeneous()).head<3>();
      EXPECT_LT((pa - pb).norm(), 0.0009) << i << " " << v;  // compact: 1 mm steps, error <= 0.87 mm
    }
    ASSERT_EQ(nb.mesh.uvs.size(), na.mesh.uvs.size());
    for (size_t v = 0; v < nb.mesh.uvs.size(); ++v) EXPECT_LT((nb.mesh.uvs[v] - na.mesh.uvs[v]).norm(), 1e-3f);
    EXPECT_EQ(nb.mesh.colors, na.mesh.colors) << i;
    EXPECT_EQ(nb.points.colors, na.points.colors) << i;
  }
  const Mesh& atlas_like = b->nodes.back().mesh;  // read back as 4 nodes: keyframe1's points are a node of their own
  EXPECT_EQ(atlas_like.texture_mime, "image/jpeg");
  EXPECT_EQ(atlas_like.texture.width, 32);
  fs::remove_all(dir);
}

TEST(GltfFlavors, ConvertGoesBothWaysAndCopiesAJpegByteForByte) {
  auto compact = encode_glb(test::sample_scene(), {});
  ASSERT_TRUE(compact.ok());
  GlbWriteOptions to_compat;
  to_compat.flavor = GlbFlavor::kCompat;
  auto compat = convert_glb(compact->data(), compact->size(), to_compat);
  ASSERT_TRUE(compat.ok()) << compat.error().message;
  auto back = convert_glb(compat->data(), compat->size(), {});
  ASSERT_TRUE(back.ok()) << back.error().message;
  const json j = json_of(*back);
  EXPECT_NE(j.dump().find("EXT_meshopt_compression"), std::string::npos);
  auto a = decode_glb(compact->data(), compact->size()), b = decode_glb(compat->data(), compat->size());
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_EQ(a->nodes.size(), b->nodes.size());
  for (size_t i = 0; i < a->nodes.size(); ++i) EXPECT_EQ(b->nodes[i].name, a->nodes[i].name);  // not "x_mesh_mesh"
  EXPECT_EQ(a->nodes[0].mesh.texture_encoded, b->nodes[0].mesh.texture_encoded);  // no JPEG generation loss
  const std::vector<std::uint8_t> junk = {'g', 'l', 'T', 'F', 2, 0, 0, 0, 12, 0, 0, 0};
  auto bad = convert_glb(junk.data(), junk.size(), to_compat);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, ErrorCode::kInvalidInput);
}

TEST(GltfFlavors, ConvertCliFailsInOneLineWithExitTwoAndWritesNothing) {
  const std::string dir = test::temp_dir("gltf-convert-cli");
  const std::string bin = test::rgbdcast_binary();
  ASSERT_TRUE(fs::exists(bin)) << bin;
  {
    std::ofstream(dir + "/truncated.glb", std::ios::binary) << "glTF\x02";
    std::ofstream(dir + "/text.glb") << "not a GLB at all\n";
  }
  auto good = encode_glb(test::sample_scene(), {});
  ASSERT_TRUE(good.ok());
  ASSERT_TRUE(write_file_atomically(dir + "/good.glb", *good).ok());
  struct Case {
    std::string args, says;
  };
  const std::vector<Case> cases = {
      {dir + "/missing.glb -o " + dir + "/out.glb", "missing.glb"},
      {dir + "/truncated.glb -o " + dir + "/out.glb", "truncated.glb"},
      {dir + "/text.glb -o " + dir + "/out.glb", "text.glb"},
      {dir + " -o " + dir + "/out.glb", "not a readable file"},
      {dir + "/good.glb --flavor tiny -o " + dir + "/out.glb", "unknown GLB flavor 'tiny'"},
  };
  for (const auto& c : cases) {
    const auto r = test::run_command(bin + " convert " + c.args);
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_EQ(r.err.rfind("rgbdcast convert: error: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(c.says), std::string::npos) << r.err;
  }
  size_t files = 0;
  for (const auto& e : fs::directory_iterator(dir)) files += e.path().filename() != "out.glb";
  EXPECT_FALSE(fs::exists(dir + "/out.glb"));
  EXPECT_EQ(files, 3u);  // the inputs only: no temporary file left behind
  // Into a folder that does not exist: an error, nothing written.
  const auto r = test::run_command(bin + " convert " + dir + "/good.glb -o " + dir + "/no/such/dir/out.glb");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  // And it works: the reduce flag too.
  const auto ok = test::run_command(bin + " convert " + dir + "/good.glb -o " + dir + "/out.glb");
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_NE(ok.out.find("(compat, "), std::string::npos) << ok.out;
  auto scene = read_glb_file(dir + "/out.glb");
  ASSERT_TRUE(scene.ok());
  EXPECT_EQ(scene->nodes.size(), 4u);  // 3 nodes, the second with a mesh and points
  const auto bad_reduce = test::run_command(bin + " reduce --input " + dir + " --flavor wire --out " + dir + "/r.glb");
  EXPECT_EQ(bad_reduce.exit_code, 2) << bad_reduce.err;
  EXPECT_EQ(bad_reduce.err.rfind("rgbdcast reduce: error: unknown GLB flavor 'wire'", 0), 0u) << bad_reduce.err;
  fs::remove_all(dir);
}

}  // namespace
