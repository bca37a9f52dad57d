// GLBs merged without decoding (gltf/glb_merge.h): the sample scene in each flavour (meshopt with its fallback buffer,
// plain floats, Draco), merged in memory and from files, is one validator-clean GLB that decodes to the parts'
// nodes, cameras and triangles; any byte range of a file merge equals the in-memory bytes; parts that hold what the
// merge does not rebase are refused.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>

#include "gltf/glb_container.h"
#include "gltf/glb_merge.h"
#include "gltf/gltf_io.h"
#include "tests/common/gltf_validator.h"
#include "tests/common/test_data.h"
#include "tests/gltf/sample_scenes.h"

using namespace rgbdcast;
using nlohmann::json;

namespace {

std::vector<std::uint8_t> encoded(const Scene& scene, GlbFlavor flavor, GeometryCodec codec = GeometryCodec::kMeshopt) {
  GlbWriteOptions options;
  options.flavor = flavor;
  options.geometry_codec = codec;
  auto glb = encode_glb(scene, options);
  EXPECT_TRUE(glb) << glb.error().message;
  return glb ? *glb : std::vector<std::uint8_t>();
}

// The sample scene moved along x, so merged parts do not coincide.
Scene shifted(double x_m) {
  Scene s = test::sample_scene();
  for (auto& n : s.nodes) n.to_world(0, 3) += x_m;
  for (auto& c : s.cameras) c.camera_to_world(0, 3) += x_m;
  return s;
}

json json_of(const std::vector<std::uint8_t>& glb) {
  auto chunks = glb::parse_glb(glb.data(), glb.size());
  return chunks ? json::parse(chunks->json, nullptr, false) : json();
}

std::vector<std::uint8_t> with_json(const std::vector<std::uint8_t>& glb, const json& doc) {
  auto chunks = glb::parse_glb(glb.data(), glb.size());
  return glb::pack_glb(doc.dump(), chunks->bin);
}

std::string write_file(const std::string& dir, const std::string& name, const std::vector<std::uint8_t>& bytes) {
  const std::string path = dir + "/" + name;
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  return path;
}

}  // namespace

TEST(GlbMerge, EveryFlavourMergesIntoOneValidGlbWithEveryTriangle) {
  const std::string dir = test::temp_dir("glb-merge");
  const Scene a = shifted(0.0), b = shifted(2.0), c = shifted(-2.0);
  const std::vector<std::vector<std::uint8_t>> parts = {encoded(a, GlbFlavor::kCompact), encoded(b, GlbFlavor::kCompat),
                                                        encoded(c, GlbFlavor::kCompact, GeometryCodec::kDraco),
                                                        encoded(b, GlbFlavor::kCompact)};
  auto merged = glb::merge_glbs(parts);
  ASSERT_TRUE(merged) << merged.error().message;
  const std::string path = write_file(dir, "merged.glb", *merged);
  EXPECT_GLTF_VALID(path);

  auto scene = decode_glb(merged->data(), merged->size());
  ASSERT_TRUE(scene) << scene.error().message;
  EXPECT_EQ(scene->triangle_count(), a.triangle_count() + 2 * b.triangle_count() + c.triangle_count());
  size_t nodes = 0, cameras = 0;
  for (const auto& part : parts) {
    auto decoded = decode_glb(part.data(), part.size());
    ASSERT_TRUE(decoded) << decoded.error().message;
    nodes += decoded->nodes.size();
    cameras += decoded->cameras.size();
  }
  EXPECT_EQ(scene->nodes.size(), nodes);
  EXPECT_EQ(scene->cameras.size(), cameras);
  EXPECT_EQ(cameras, 4 * a.cameras.size());
  // Part 1 (b) keeps its place: its first camera is where b's is.
  ASSERT_GE(scene->cameras.size(), 2 * a.cameras.size());
  EXPECT_NEAR(scene->cameras[a.cameras.size()].camera_to_world(0, 3), b.cameras[0].camera_to_world(0, 3), 1e-4);

  // One BIN buffer and one meshopt fallback buffer; the extensions of every part, each named once.
  const json doc = json_of(*merged);
  ASSERT_EQ(doc["buffers"].size(), 2u);
  EXPECT_TRUE(doc["buffers"][1]["extensions"]["EXT_meshopt_compression"]["fallback"].get<bool>());
  for (const char* e : {"EXT_meshopt_compression", "KHR_draco_mesh_compression", "KHR_mesh_quantization"}) {
    EXPECT_EQ(std::count(doc["extensionsUsed"].begin(), doc["extensionsUsed"].end(), e), 1) << e;
    EXPECT_EQ(std::count(doc["extensionsRequired"].begin(), doc["extensionsRequired"].end(), e), 1) << e;
  }
  EXPECT_EQ(doc["scenes"][0]["nodes"].size(), 4u);

  // One part merges into itself, byte-different but the same scene.
  auto single = glb::merge_glbs({parts[0]});
  ASSERT_TRUE(single);
  auto single_scene = decode_glb(single->data(), single->size());
  ASSERT_TRUE(single_scene);
  EXPECT_EQ(single_scene->triangle_count(), a.triangle_count());
}

TEST(GlbMerge, AFileMergeStreamsTheSameBytesInAnyRanges) {
  const std::string dir = test::temp_dir("glb-file-merge");
  std::vector<std::vector<std::uint8_t>> parts;
  std::vector<std::string> paths;
  for (int i = 0; i < 5; ++i) {
    parts.push_back(encoded(shifted(i), i % 2 ? GlbFlavor::kCompat : GlbFlavor::kCompact));
    paths.push_back(write_file(dir, std::to_string(i) + ".glb", parts.back()));
  }
  auto memory = glb::merge_glbs(parts);
  ASSERT_TRUE(memory);
  auto files = glb::GlbFileMerge::open(paths);
  ASSERT_TRUE(files) << files.error().message;
  ASSERT_EQ((*files)->size(), memory->size());
  EXPECT_EQ((*files)->parts(), 5u);
  // The files may go once opened: what is open is read whole.
  for (const auto& p : paths) std::filesystem::remove(p);
  for (size_t step : {size_t(1000), size_t(4096), size_t(7), size_t(1) << 20}) {
    std::string out(memory->size(), '\0');
    for (size_t at = 0; at < out.size(); at += step)
      ASSERT_TRUE((*files)->read(at, out.data() + at, std::min(step, out.size() - at))) << at;
    EXPECT_EQ(0, std::memcmp(out.data(), memory->data(), out.size())) << "step " << step;
  }
  char byte = 0;
  EXPECT_FALSE((*files)->read(memory->size(), &byte, 1));
  EXPECT_FALSE((*files)->read(memory->size() - 1, &byte, 2));

  auto missing = glb::GlbFileMerge::open({dir + "/none.glb"});
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().code, ErrorCode::kNotFound);
  EXPECT_EQ(missing.error().message.find(dir), std::string::npos) << "the error quotes a server path";
  const std::string junk = write_file(dir, "junk.glb", std::vector<std::uint8_t>(100, 7));
  auto bad = glb::GlbFileMerge::open({junk});
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().code, ErrorCode::kInvalidInput);
}

TEST(GlbMerge, PartsItCannotRebaseAreRefused) {
  const auto glb = encoded(shifted(0.0), GlbFlavor::kCompact);
  const json doc = json_of(glb);
  auto refused = [&](const std::string& what, const std::function<void(json&)>& edit) {
    json d = doc;
    edit(d);
    auto merged = glb::merge_glbs({glb, with_json(glb, d)});
    ASSERT_FALSE(merged) << what;
    EXPECT_EQ(merged.error().code, ErrorCode::kInvalidInput) << what;
    EXPECT_NE(merged.error().message.find("part 1"), std::string::npos) << merged.error().message;
  };
  refused("an external buffer", [](json& d) { d["buffers"][0]["uri"] = "../../etc/passwd"; });
  refused("an accessor out of range", [](json& d) { d["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 999; });
  refused("a negative child", [](json& d) { d["nodes"][0]["children"] = json::array({-1}); });
  refused("a node out of range", [](json& d) { d["scenes"][0]["nodes"] = json::array({12345}); });
  refused("a bufferView's buffer", [](json& d) { d["bufferViews"][0]["buffer"] = 7; });
  refused("a material's texture",
          [](json& d) { d["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["index"] = 40; });
  refused("skins", [](json& d) { d["skins"] = json::array({json{{"joints", json::array({0})}}}); });
  refused("document extensions", [](json& d) {
    d["extensions"] = {{"KHR_lights_punctual", {{"lights", json::array()}}}};
  });
  refused("an external image", [](json& d) { d["images"][0] = {{"uri", "file:///etc/passwd"}}; });
  auto not_json = glb::merge_glbs({glb::pack_glb("{not json", {})});
  EXPECT_FALSE(not_json);
  EXPECT_FALSE(glb::merge_glbs({}));
}
