// The two GLB flavours (gltf/gltf_io.h), and compact with Draco geometry, in the viewers people open them in:
// Blender 3.4 and Assimp 5.2.5 (Debian's blender and assimp-utils), three.js 0.187 in headless Chromium, and the
// Khronos validator. The files come from the real command line (rgbdcast reduce --flavor, rgbdcast convert) on real
// data: TUM fr1/xyz frame 0, and a multi-keyframe scene of the augmented ICL-NUIM living room (--sequence
// --keyframe-gap 1). Every count a viewer reports is compared with the counts of the scene that was written (read back
// with read_glb_file). KHR_draco_mesh_compression: three.js (DRACOLoader, its own decoder from node_modules) reads it;
// Assimp reads the TUM file but not the ICL sequence; Debian's Blender 3.4 reads neither (no libextern_draco.so). A
// viewer that is not installed skips its test on a developer machine and fails it under CI=true. The files are made
// once per rgbdcast binary in <build>/tests/gltf/viewer-files (see files()).
#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>

#include "base/atomic_file.h"
#include "gltf/glb_container.h"
#include "gltf/gltf_io.h"
#include "tests/common/gltf_validator.h"
#include "tests/common/run_command.h"
#include "tests/common/test_data.h"
#include "tests/gltf/headless_chromium.h"

using namespace rgbdcast;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

constexpr const char* kTum = "tum/rgbd_dataset_freiburg1_xyz";
constexpr const char* kIcl = "augmented_icl_livingroom";

bool in_ci() { return std::getenv("CI") && std::string(std::getenv("CI")) == "true"; }

// What a viewer should find in a file: counted on the scene rgbdcast reads back from it.
struct Counts {
  size_t meshes = 0, vertices = 0, triangles = 0, textures = 0, cameras = 0;
  // Triangles with three distinct vertices and a vertex set no other triangle has: what Blender keeps (its mesh
  // validation merges a triangle written twice, in either winding, and drops degenerate ones).
  size_t distinct_faces = 0;
  std::vector<std::pair<int, int>> texture_sizes;
};

std::string describe(const Counts& c) {
  std::ostringstream os;
  os << c.meshes << " meshes, " << c.vertices << " vertices, " << c.triangles << " triangles, " << c.textures
     << " textures, " << c.cameras << " cameras (" << c.distinct_faces << " distinct faces)";
  return os.str();
}

Counts counts_of_file(const std::string& path) {
  Counts c;
  auto scene = read_glb_file(path);
  EXPECT_TRUE(scene.ok()) << path << ": " << (scene.ok() ? "" : scene.error().message);
  if (!scene.ok()) return c;
  for (const SceneNode& n : scene->nodes) {
    if (n.mesh.triangle_count() == 0) continue;
    ++c.meshes;
    c.vertices += n.mesh.positions.size();
    c.triangles += n.mesh.triangle_count();
    std::set<std::array<std::uint32_t, 3>> faces;
    for (size_t t = 0; t + 2 < n.mesh.indices.size(); t += 3) {
      std::array<std::uint32_t, 3> f = {n.mesh.indices[t], n.mesh.indices[t + 1], n.mesh.indices[t + 2]};
      std::sort(f.begin(), f.end());
      if (f[0] != f[1] && f[1] != f[2]) faces.insert(f);
    }
    c.distinct_faces += faces.size();
    if (n.mesh.textured()) {
      ++c.textures;
      c.texture_sizes.emplace_back(n.mesh.texture.width, n.mesh.texture.height);
    }
  }
  c.cameras = scene->cameras.size();
  return c;
}

json glb_json(const std::string& path) {
  auto bytes = read_file_bytes(path, size_t(1) << 30);
  if (!bytes) return json();
  auto chunks = glb::parse_glb(bytes->data(), bytes->size());
  return chunks ? json::parse(chunks->json, nullptr, false) : json();
}

// The files every test here looks at, made once per test binary by the real command line (compact, compat, and
// compact with Draco geometry).
struct Files {
  std::string dir, why_not;
  std::string tum_compact, tum_compat, tum_converted, seq_compact, seq_compat, tum_draco, seq_draco;
  double tum_reduce_s = 0, seq_reduce_s = 0;
};

std::string run_ok(const std::string& cmd, std::string* why_not) {
  const auto r = test::run_command(cmd);
  if (r.exit_code != 0 && why_not->empty()) *why_not = cmd + " -> exit " + std::to_string(r.exit_code) + ": " + r.err;
  return r.out;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// What the files were made from: the rgbdcast binary (size and time). ctest runs every test in its own process; the
// files are made by the first and reused by the others while the binary is the same.
std::string stamp_of(const std::string& bin) {
  std::error_code ec;
  const auto size = fs::file_size(bin, ec);
  const auto time = fs::last_write_time(bin, ec).time_since_epoch().count();
  return bin + " " + std::to_string(size) + " " + std::to_string(time) + "\n";
}

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

const Files& files() {
  static const Files f = [] {
    Files f;
    f.dir = test::binary_path("tests/gltf/viewer-files");
    fs::create_directories(f.dir);
    const std::string bin = test::rgbdcast_binary();
    f.tum_compact = f.dir + "/tum-compact.glb";
    f.tum_compat = f.dir + "/tum-compat.glb";
    f.tum_converted = f.dir + "/tum-converted.glb";
    f.seq_compact = f.dir + "/icl-seq-compact.glb";
    f.seq_compat = f.dir + "/icl-seq-compat.glb";
    f.tum_draco = f.dir + "/tum-draco.glb";
    f.seq_draco = f.dir + "/icl-seq-draco.glb";
    // One maker at a time (ctest -j): the others wait on the lock, then find the stamp.
    const int lock = ::open((f.dir + "/.lock").c_str(), O_CREAT | O_RDWR | O_CLOEXEC, 0644);
    if (lock >= 0) ::flock(lock, LOCK_EX);
    const std::string stamp_file = f.dir + "/stamp", stamp = stamp_of(bin);
    if (slurp(stamp_file) != stamp) {
      fs::remove(stamp_file);
      const std::string tum = "reduce --preset paper --input " + test::data_path(kTum) + " --frame 0";
      auto t0 = std::chrono::steady_clock::now();
      run_ok(bin + " " + tum + " --out " + f.tum_compact, &f.why_not);
      f.tum_reduce_s = seconds_since(t0);
      run_ok(bin + " " + tum + " --flavor compat --out " + f.tum_compat, &f.why_not);
      run_ok(bin + " convert " + f.tum_compact + " --flavor compat -o " + f.tum_converted, &f.why_not);
      t0 = std::chrono::steady_clock::now();
      run_ok(bin + " reduce --preset paper --input " + test::data_path(kIcl) +
                 " --sequence --keyframe-gap 1 --no-progress --out " + f.seq_compact,
             &f.why_not);
      f.seq_reduce_s = seconds_since(t0);
      run_ok(bin + " convert " + f.seq_compact + " -o " + f.seq_compat, &f.why_not);
      run_ok(bin + " " + tum + " --geometry-codec draco --out " + f.tum_draco, &f.why_not);
      run_ok(bin + " convert " + f.seq_compact + " --flavor compact --geometry-codec draco -o " + f.seq_draco,
             &f.why_not);
      std::printf("[ files ] made in %s: reduce TUM frame 0 %.1f s, reduce ICL sequence %.1f s\n", f.dir.c_str(),
                  f.tum_reduce_s, f.seq_reduce_s);
      if (f.why_not.empty()) std::ofstream(stamp_file) << stamp;
    }
    if (lock >= 0) ::close(lock);
    return f;
  }();
  return f;
}

#define REQUIRE_FILES()                                      \
  do {                                                       \
    REQUIRE_DATA(kTum);                                      \
    REQUIRE_DATA(kIcl);                                      \
    ASSERT_TRUE(files().why_not.empty()) << files().why_not; \
  } while (0)

// A viewer binary from Debian, or a skip (a failure under CI).
#define REQUIRE_TOOL(path, package)                                                                   \
  do {                                                                                                \
    if (!fs::exists(path)) {                                                                          \
      const std::string why_ = std::string(path) + " missing (Debian " package ", scripts/setup.sh)"; \
      if (in_ci()) FAIL() << why_;                                                                    \
      GTEST_SKIP() << why_;                                                                           \
    }                                                                                                 \
  } while (0)

// --- Blender -------------------------------------------------------------------------------------------------------

json blender_counts(const std::string& glb, double* seconds) {
  const std::string out = glb + ".blender.json";
  fs::remove(out);
  const auto t0 = std::chrono::steady_clock::now();
  const auto r = test::run_command("/usr/bin/blender -b --factory-startup --python " +
                                   test::source_path("tools/blender_gltf_counts.py") + " -- " + glb + " " + out);
  *seconds = seconds_since(t0);
  std::ifstream in(out);
  if (r.exit_code != 0 || !in)
    return {{"ok", false}, {"error", "blender exit " + std::to_string(r.exit_code) + ": " + r.err}};
  return json::parse(in, nullptr, false);
}

void expect_blender_opens(const std::string& glb, const std::string& tag) {
  const Counts want = counts_of_file(glb);
  double s = 0;
  const json got = blender_counts(glb, &s);
  ASSERT_TRUE(got.value("ok", false)) << tag << ": " << got.dump();
  std::printf("[ blender ] %s in %.1f s: %s; file: %s\n", tag.c_str(), s, got.dump().c_str(), describe(want).c_str());
  EXPECT_EQ(got["meshes"].get<size_t>(), want.meshes) << tag;
  EXPECT_EQ(got["vertices"].get<size_t>(), want.vertices) << tag;
  EXPECT_EQ(got["faces"].get<size_t>(), want.distinct_faces) << tag;
  EXPECT_EQ(got["uv_layers"].get<size_t>(), want.textures) << tag;  // one UV layer per textured mesh
  EXPECT_EQ(got["images"].get<size_t>(), want.textures) << tag;
  EXPECT_EQ(got["cameras"].get<size_t>(), want.cameras) << tag;
  std::vector<std::pair<int, int>> sizes;
  for (const auto& wh : got["image_sizes"]) sizes.emplace_back(wh[0].get<int>(), wh[1].get<int>());
  std::sort(sizes.begin(), sizes.end());
  auto want_sizes = want.texture_sizes;
  std::sort(want_sizes.begin(), want_sizes.end());
  EXPECT_EQ(sizes, want_sizes) << tag;
}

TEST(GltfViewers, BlenderOpensTheCompatGlbOfATumFrame) {
  REQUIRE_TOOL("/usr/bin/blender", "blender");
  REQUIRE_FILES();
  expect_blender_opens(files().tum_compat, "TUM frame 0 compat");
}

TEST(GltfViewers, BlenderOpensTheCompatGlbOfAMultiKeyframeScene) {
  REQUIRE_TOOL("/usr/bin/blender", "blender");
  REQUIRE_FILES();
  const Counts c = counts_of_file(files().seq_compat);
  ASSERT_GE(c.meshes, 2u) << "the sequence gave one keyframe: " << describe(c);
  ASSERT_GE(c.cameras, 2u);
  expect_blender_opens(files().seq_compat, "ICL sequence compat");
}

TEST(GltfViewers, BlenderCannotOpenTheCompactGlb) {
  // Why compat exists: Blender 3.4's importer has no meshopt decoder.
  REQUIRE_TOOL("/usr/bin/blender", "blender");
  REQUIRE_FILES();
  double s = 0;
  const json got = blender_counts(files().tum_compact, &s);
  EXPECT_FALSE(got.value("ok", true)) << got.dump();
  EXPECT_NE(got.value("error", "").find("EXT_meshopt_compression"), std::string::npos) << got.dump();
}

TEST(GltfViewers, BlenderCannotOpenTheDracoGlb) {
  // Blender 3.4's importer knows KHR_draco_mesh_compression, but Debian's blender package does not ship the Draco
  // library it loads (libextern_draco.so): the compat flavour is the answer for Blender.
  REQUIRE_TOOL("/usr/bin/blender", "blender");
  REQUIRE_FILES();
  double s = 0;
  const json got = blender_counts(files().tum_draco, &s);
  EXPECT_FALSE(got.value("ok", true)) << got.dump();
  EXPECT_NE(got.value("error", "").find("libextern_draco"), std::string::npos) << got.dump();
}

// --- Assimp --------------------------------------------------------------------------------------------------------

struct AssimpInfo {
  int exit_code = -1;
  std::string text;
  long meshes = -1, vertices = -1, faces = -1, textures = -1, cameras = -1;
};

long field(const std::string& text, const std::string& name) {
  std::smatch m;
  if (std::regex_search(text, m, std::regex(name + R"(:\s+(\d+))"))) return std::stol(m[1]);
  return -1;
}

// `assimp info -r` (raw: no post-processing, so the counts are the file's, not Assimp's joined or split vertices).
AssimpInfo assimp_info(const std::string& glb) {
  const auto r = test::run_command("/usr/bin/assimp info " + glb + " -r");
  AssimpInfo a;
  a.exit_code = r.exit_code;
  a.text = r.out + r.err;
  a.meshes = field(r.out, "Meshes");
  a.vertices = field(r.out, "Vertices");
  a.faces = field(r.out, "Faces");
  a.textures = field(r.out, R"(Textures \(embed\.\))");
  a.cameras = field(r.out, "Cameras");
  return a;
}

void expect_assimp_opens(const std::string& glb, const std::string& tag) {
  const Counts want = counts_of_file(glb);
  const AssimpInfo got = assimp_info(glb);
  ASSERT_EQ(got.exit_code, 0) << tag << ":\n" << got.text;
  std::printf("[ assimp ] %s: meshes %ld, vertices %ld, faces %ld, embedded textures %ld, cameras %ld; file: %s\n",
              tag.c_str(), got.meshes, got.vertices, got.faces, got.textures, got.cameras, describe(want).c_str());
  EXPECT_EQ(got.meshes, long(want.meshes)) << got.text;
  EXPECT_EQ(got.vertices, long(want.vertices)) << got.text;
  EXPECT_EQ(got.faces, long(want.triangles)) << got.text;
  EXPECT_EQ(got.textures, long(want.textures)) << got.text;
  EXPECT_EQ(got.cameras, long(want.cameras)) << got.text;
}

TEST(GltfViewers, AssimpOpensTheCompatGlbOfATumFrame) {
  REQUIRE_TOOL("/usr/bin/assimp", "assimp-utils");
  REQUIRE_FILES();
  expect_assimp_opens(files().tum_compat, "TUM frame 0 compat (reduce --flavor compat)");
  expect_assimp_opens(files().tum_converted, "TUM frame 0 compat (convert)");
}

TEST(GltfViewers, AssimpOpensTheCompatGlbOfAMultiKeyframeScene) {
  REQUIRE_TOOL("/usr/bin/assimp", "assimp-utils");
  REQUIRE_FILES();
  expect_assimp_opens(files().seq_compat, "ICL sequence compat");
}

TEST(GltfViewers, AssimpOpensTheDracoGlbOfATumFrameButNotTheIclSequence) {
  // Debian's Assimp 5.2.5 is built with Draco: it reads KHR_draco_mesh_compression on TUM frame 0 (one mesh, 26k
  // points, 16-bit indices). The 5-keyframe ICL file (its first mesh 72k points, 32-bit indices), which three.js
  // and decode_glb read, it refuses with "Invalid accessor without data"; the cause is not known yet. compat is
  // the answer for Assimp.
  REQUIRE_TOOL("/usr/bin/assimp", "assimp-utils");
  REQUIRE_FILES();
  expect_assimp_opens(files().tum_draco, "TUM frame 0 draco (reduce --geometry-codec draco)");
  const AssimpInfo seq = assimp_info(files().seq_draco);
  EXPECT_NE(seq.exit_code, 0) << "Assimp now reads the ICL Draco file: update README.md and this test";
  EXPECT_NE(seq.text.find("Invalid accessor without data"), std::string::npos) << seq.text;
}

TEST(GltfViewers, AssimpCannotOpenTheCompactOrAQuantizedGlb) {
  // Why compat has float positions: Assimp 5.2.5 has no meshopt decoder, and it reads KHR_mesh_quantization's int16
  // positions as floats, so its post-processing drops every triangle.
  REQUIRE_TOOL("/usr/bin/assimp", "assimp-utils");
  REQUIRE_FILES();
  const AssimpInfo compact = assimp_info(files().tum_compact);
  EXPECT_NE(compact.exit_code, 0);
  EXPECT_NE(compact.text.find("missing the \"uri\" attribute"), std::string::npos) << compact.text;
  auto bytes = read_file_bytes(files().tum_compat, size_t(1) << 30);
  ASSERT_TRUE(bytes.ok());
  GlbWriteOptions quantized;  // compact without meshopt: what --no-meshopt writes
  quantized.meshopt = false;
  auto q = convert_glb(bytes->data(), bytes->size(), quantized);
  ASSERT_TRUE(q.ok()) << q.error().message;
  const std::string path = files().dir + "/tum-quantized.glb";
  ASSERT_TRUE(write_file_atomically(path, *q).ok());
  const auto r = test::run_command("/usr/bin/assimp info " + path);  // with Assimp's default post-processing
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE((r.out + r.err).find("No meshes remaining"), std::string::npos) << r.out << r.err;
}

// --- three.js ------------------------------------------------------------------------------------------------------

void expect_threejs_opens(const std::string& glb, bool meshopt_decoder, const std::string& tag,
                          bool draco_decoder = false) {
  const std::string chromium = test::find_chromium();
  if (chromium.empty() || !fs::exists(test::source_path("tools/node_modules/three/build/three.module.js"))) {
    const std::string why =
        chromium.empty() ? "chromium not installed" : "tools/node_modules/three missing (scripts/setup.sh)";
    if (in_ci()) FAIL() << why;
    GTEST_SKIP() << why;
  }
  const Counts want = counts_of_file(glb);
  const auto post = test::run_tools_page(chromium,
                                         std::string("threejs_view.html?report=counts&glb=/scene.glb&meshopt=") +
                                             (meshopt_decoder ? "1" : "0") + "&draco=" + (draco_decoder ? "1" : "0"),
                                         {{"/scene.glb", glb}}, files().dir, tag, 320, 240);
  ASSERT_TRUE(post.reported) << tag << ": the page did not report; see " << post.log;
  ASSERT_TRUE(post.ok) << tag << ": " << post.body;
  const json got = json::parse(post.body, nullptr, false);
  ASSERT_TRUE(got.is_object()) << post.body;
  std::printf("[ three.js ] %s in %.1f s: %s; file: %s\n", tag.c_str(), post.ms / 1000.0, got.dump().c_str(),
              describe(want).c_str());
  EXPECT_EQ(got["meshes"].get<size_t>(), want.meshes);
  EXPECT_EQ(got["vertices"].get<size_t>(), want.vertices);
  EXPECT_EQ(got["triangles"].get<size_t>(), want.triangles);
  EXPECT_EQ(got["textures"].get<size_t>(), want.textures);
  EXPECT_EQ(got["cameras"].get<size_t>(), want.cameras);
}

TEST(GltfViewers, ThreeJsOpensTheCompactGlbWithMeshoptDecoder) {
  REQUIRE_FILES();
  expect_threejs_opens(files().tum_compact, /*meshopt_decoder=*/true, "threejs-tum-compact");
  expect_threejs_opens(files().seq_compact, /*meshopt_decoder=*/true, "threejs-icl-compact");
}

TEST(GltfViewers, ThreeJsOpensTheDracoGlbWithDracoLoader) {
  REQUIRE_FILES();
  expect_threejs_opens(files().tum_draco, /*meshopt_decoder=*/false, "threejs-tum-draco", /*draco_decoder=*/true);
  expect_threejs_opens(files().seq_draco, /*meshopt_decoder=*/false, "threejs-icl-draco", /*draco_decoder=*/true);
}

TEST(GltfViewers, ThreeJsOpensTheCompatGlbWithoutAnyDecoder) {
  REQUIRE_FILES();
  expect_threejs_opens(files().tum_compat, /*meshopt_decoder=*/false, "threejs-tum-compat");
  expect_threejs_opens(files().seq_compat, /*meshopt_decoder=*/false, "threejs-icl-compat");
}

// --- what the files are --------------------------------------------------------------------------------------------

TEST(GltfViewers, ValidatorFindsNoErrorsOrWarningsInEitherFlavour) {
  REQUIRE_FILES();
  for (const std::string& f : {files().tum_compact, files().tum_compat, files().tum_converted, files().seq_compact,
                               files().seq_compat, files().tum_draco, files().seq_draco})
    EXPECT_GLTF_VALID(f);
}

TEST(GltfViewers, CompatUsesFloatsAJpegAndNoExtensionAViewerMustDecode) {
  REQUIRE_FILES();
  for (const std::string& f : {files().tum_compat, files().tum_converted, files().seq_compat}) {
    const json doc = glb_json(f);
    ASSERT_TRUE(doc.is_object()) << f;
    EXPECT_FALSE(doc.contains("extensionsRequired")) << f << ": " << doc["extensionsRequired"].dump();
    for (const auto& e : doc.value("extensionsUsed", json::array())) {
      EXPECT_EQ(e, "KHR_materials_unlit") << f;
    }
    for (const auto& mesh : doc["meshes"])
      for (const auto& prim : mesh["primitives"])
        for (const char* attr : {"POSITION", "TEXCOORD_0", "COLOR_0"}) {
          if (!prim["attributes"].contains(attr)) continue;
          EXPECT_EQ(doc["accessors"][prim["attributes"][attr].get<size_t>()]["componentType"], 5126)
              << f << " " << attr;
        }
    for (const auto& img : doc["images"]) EXPECT_EQ(img["mimeType"], "image/jpeg") << f;
    EXPECT_EQ(doc["buffers"].size(), 1u) << f;
  }
  // The same scene as the compact file: reduce --flavor compat, convert and the compact file agree.
  const Counts compact = counts_of_file(files().tum_compact), compat = counts_of_file(files().tum_compat),
               converted = counts_of_file(files().tum_converted);
  EXPECT_EQ(describe(compat), describe(compact));
  EXPECT_EQ(describe(converted), describe(compact));
  EXPECT_EQ(describe(counts_of_file(files().seq_compat)), describe(counts_of_file(files().seq_compact)));
  const auto compact_bytes = fs::file_size(files().tum_compact), compat_bytes = fs::file_size(files().tum_compat);
  std::printf("[ bytes ] TUM frame 0: compact %zu, compat %zu\n", size_t(compact_bytes), size_t(compat_bytes));
  EXPECT_LT(compact_bytes, compat_bytes);
}

}  // namespace
