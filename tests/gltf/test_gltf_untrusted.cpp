// decode_glb against attacks: URIs that name server files, JSON nested 15,000 deep, accessors that claim
// more elements than their bytes, zero-filled accessors, mesh instancing past the vertex cap, oversized images and
// meshopt output. Each is a one-line kInvalidInput naming the limit; none touches the filesystem or allocates for
// what the file only claims (peak RSS is measured in a child process).
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "gltf/glb_container.h"
#include "gltf/gltf_io.h"
#include "scene/json_nesting.h"
#include "tests/gltf/hostile_glbs.h"
#include "tests/gltf/sample_scenes.h"

using namespace rgbdcast;
using rgbdcast::test::Bytes;

namespace {

#if defined(__SANITIZE_ADDRESS__)
#define RGBDCAST_TEST_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define RGBDCAST_TEST_ASAN 1
#endif
#endif
#ifdef RGBDCAST_TEST_ASAN
constexpr long kSanitizerSlackMiB = 256;  // ASan's quarantine keeps freed blocks resident
#else
constexpr long kSanitizerSlackMiB = 0;
#endif

Result<Scene> decode(const Bytes& b, const GlbDecodeLimits& limits = {}) {
  return decode_glb(b.data(), b.size(), limits);
}

// The error of a decode that must fail, with the checks every error passes.
std::string error_of(const Bytes& b, const GlbDecodeLimits& limits = {}) {
  auto r = decode(b, limits);
  EXPECT_FALSE(r.ok());
  if (r.ok()) return "";
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput) << r.error().message;
  EXPECT_EQ(r.error().message.find('\n'), std::string::npos);
  return r.error().message;
}

// Growth of the peak RSS (MiB) while `work` runs, in a forked child so that earlier tests' peaks do not hide it.
long peak_growth_mib(const std::function<void()>& work) {
  int fds[2];
  if (pipe(fds) != 0) return -1;
  const pid_t pid = fork();
  if (pid == 0) {
    rusage before{}, after{};
    getrusage(RUSAGE_SELF, &before);
    work();
    getrusage(RUSAGE_SELF, &after);
    const long mib = (after.ru_maxrss - before.ru_maxrss) / 1024;
    (void)!write(fds[1], &mib, sizeof mib);
    _exit(0);
  }
  close(fds[1]);
  long mib = -1;
  if (read(fds[0], &mib, sizeof mib) != sizeof mib) mib = -1;
  close(fds[0]);
  waitpid(pid, nullptr, 0);
  return mib;
}

}  // namespace

TEST(GltfUntrusted, SampleDecodes) {
  auto r = decode(test::plain_sample_glb());
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_GE(r->nodes.size(), 2u);
  EXPECT_EQ(r->nodes[0].mesh.texture.width, 64);
}

TEST(GltfUntrusted, BufferUriNamingAServerFileIsRefusedWithoutOpeningIt) {
  for (const std::string uri : {"/etc/hostname", "../../../../etc/hostname", "file:///etc/hostname",
                                "%2Fetc%2Fhostname", "/nonexistent/file.bin"}) {
    const std::string e = error_of(test::glb_with_buffer_uri(uri));
    EXPECT_NE(e.find("external URI not allowed (buffers[0].uri)"), std::string::npos) << e;
    EXPECT_EQ(e.find("hostname"), std::string::npos) << "the error must not echo the path: " << e;
    EXPECT_EQ(e.find("size"), std::string::npos) << "nothing about the file may leak: " << e;
  }
  // Existing and missing files give the same answer: no oracle.
  EXPECT_EQ(error_of(test::glb_with_buffer_uri("/etc/hostname")), error_of(test::glb_with_buffer_uri("/no/such")));
}

TEST(GltfUntrusted, ImageUriIsRefused) {
  for (const std::string uri : {"/etc/hostname", "texture.png"}) {
    const std::string e = error_of(test::glb_with_image_uri(uri));
    EXPECT_NE(e.find("external URI not allowed (images[0].uri)"), std::string::npos) << e;
    EXPECT_EQ(e.find(uri), std::string::npos) << e;
  }
  const std::string e = error_of(test::glb_with_image_uri("data:image/png;base64,iVBORw0KGgo="));
  EXPECT_NE(e.find("data URI not allowed (images[0].uri)"), std::string::npos) << e;
}

TEST(GltfUntrusted, DataUriBuffersAndExtraBuffersAreRefused) {
  EXPECT_NE(
      error_of(test::glb_with_buffer_uri("data:application/octet-stream;base64,AAAA")).find("data URI not allowed"),
      std::string::npos);
  // Every uri-less buffer of a GLB is a copy of the BIN chunk in tinygltf: 1000 of them would be 1000 copies.
  const auto many = test::edit_glb(test::plain_sample_glb(), [](nlohmann::json& d) {
    for (int i = 0; i < 1000; ++i) d["buffers"].push_back(d["buffers"][0]);
  });
  EXPECT_NE(error_of(many).find("only one buffer (the BIN chunk) is allowed, found 1001"), std::string::npos);
}

TEST(GltfUntrusted, DeeplyNestedExtrasAreACleanError) {
  for (int depth : {65, 1000, 15000, 20000}) {
    const std::string e = error_of(test::glb_with_nested_extras(depth));
    EXPECT_NE(e.find("JSON nested deeper than 64 levels"), std::string::npos) << depth << ": " << e;
  }
  // 50 levels of extras inside a node (object > nodes > node > extras...) stay under 64 and decode.
  EXPECT_TRUE(decode(test::glb_with_nested_extras(50)).ok());
  GlbDecodeLimits small;
  small.max_json_bytes = 100;
  EXPECT_NE(error_of(test::plain_sample_glb(), small).find("over the limit of 100"), std::string::npos);
}

TEST(GltfUntrusted, JsonNestingScanCountsOnlyStructure) {
  EXPECT_TRUE(check_json_nesting("[[[]]]", 100, 3, "t").ok());
  EXPECT_FALSE(check_json_nesting("[[[[]]]]", 100, 3, "t").ok());
  EXPECT_TRUE(check_json_nesting(R"(["[[[[[[", "\"[[[[", {"k": "\\"}])", 100, 2, "t").ok());
  EXPECT_FALSE(check_json_nesting(R"([{"a": "\\"}, [[]]])", 100, 2, "t").ok());
  EXPECT_TRUE(check_json_nesting("]]]]}}}}[", 100, 1, "t").ok());  // unbalanced: the parser's to reject
  EXPECT_TRUE(check_json_nesting("\"unterminated [[[[", 100, 1, "t").ok());
  EXPECT_EQ(check_json_nesting(std::string(101, ' '), 100, 1, "intrinsics").error().message,
            "intrinsics: JSON is 101 bytes, over the limit of 100");
}

TEST(GltfUntrusted, AccessorClaimingMoreThanItsBytesAllocatesNothing) {
  const Bytes glb = test::glb_with_position_count(std::uint64_t(1) << 26);  // the probe's 564-byte attack
  const std::string e = error_of(glb);
  EXPECT_NE(e.find("67108864 elements do not fit in its bufferView"), std::string::npos) << e;
  const long growth = peak_growth_mib([&] { (void)decode(glb); });
  EXPECT_LT(growth, 32) << "MiB of peak RSS for a rejected accessor";
  // Counts that overflow 64-bit arithmetic.
  EXPECT_FALSE(decode(test::glb_with_position_count(UINT64_MAX)).ok());
  EXPECT_FALSE(decode(test::glb_with_position_count(std::uint64_t(1) << 62)).ok());
}

TEST(GltfUntrusted, AccessorWithoutBufferViewIsRefused) {
  const Bytes glb = test::glb_without_bufferview(std::uint64_t(1) << 26);  // claims 22 M zero triangles
  EXPECT_NE(error_of(glb).find("has no bufferView"), std::string::npos);
  EXPECT_LT(peak_growth_mib([&] { (void)decode(glb); }), 32);
}

TEST(GltfUntrusted, VerticesAndTrianglesAreCappedPerSceneCountingInstances) {
  const size_t v = test::sample_first_mesh_vertices();
  ASSERT_EQ(v, 49u);  // the 6x6 textured grid
  GlbDecodeLimits lim;
  // The other nodes: a 25-vertex mesh with its 25 points, and a 24-vertex atlas-like mesh.
  lim.max_vertices = 4 * v + 74;
  const auto three = test::glb_with_mesh_instances(3);  // 4 instances of the grid, then the coloured grid
  auto ok = decode(three, lim);
  ASSERT_TRUE(ok.ok()) << ok.error().message;
  EXPECT_EQ(ok->vertex_count(), 4 * v + 25 + 24);
  const auto four = test::glb_with_mesh_instances(4);
  EXPECT_NE(error_of(four, lim).find("over the limit of 270 vertices per scene"), std::string::npos)
      << error_of(four, lim);
  const size_t triangles = decode(test::plain_sample_glb())->triangle_count();
  EXPECT_EQ(triangles, 72u + 32u + 8u);  // 6x6 grid, 4x4 grid, 8 atlas-like triangles
  GlbDecodeLimits tri;
  tri.max_triangles = triangles - 1;
  EXPECT_NE(error_of(test::plain_sample_glb(), tri).find("over the limit of 111 triangles per scene"),
            std::string::npos);
  tri.max_triangles = triangles;
  EXPECT_TRUE(decode(test::plain_sample_glb(), tri).ok());
  // 100,000 instances of a 49-vertex, 72-triangle mesh (7.2 M triangles from 1.1 MB of JSON): past the default cap.
  // (Untextured, so that the texture budget does not stop it first.)
  const auto many = test::edit_glb(test::glb_with_mesh_instances(100000), [](nlohmann::json& d) {
    for (auto& mesh : d["meshes"])
      for (auto& prim : mesh["primitives"]) prim.erase("material");
  });
  EXPECT_NE(error_of(many).find("over the limit of 4000000 triangles per scene"), std::string::npos) << error_of(many);
}

TEST(GltfUntrusted, TextureCopiesAreChargedPerInstance) {
  GlbDecodeLimits lim;
  const size_t one = 64 * 48 * 3;  // the decoded texture; its encoded bytes come on top
  lim.max_scene_texture_bytes = 3 * one + 3 * 20000;
  EXPECT_TRUE(decode(test::glb_with_mesh_instances(1), lim).ok());
  EXPECT_NE(error_of(test::glb_with_mesh_instances(10), lim).find("textures over the limit"), std::string::npos);
}

// Patches the width/height of the sample's texture (a JPEG) in its frame header.
Bytes with_texture_size(int w, int h) {
  const Bytes glb = test::plain_sample_glb();
  auto chunks = glb::parse_glb(glb.data(), glb.size());
  const auto doc = nlohmann::json::parse(chunks->json);
  const auto& view = doc["bufferViews"][doc["images"][0]["bufferView"].get<int>()];
  const size_t off = view.value("byteOffset", size_t(0)), len = view["byteLength"].get<size_t>();
  auto bin = chunks->bin;
  for (size_t i = off; i + 9 < off + len; ++i)
    if (bin[i] == 0xFF && (bin[i + 1] == 0xC0 || bin[i + 1] == 0xC2)) {
      bin[i + 5] = static_cast<std::uint8_t>(h >> 8), bin[i + 6] = static_cast<std::uint8_t>(h);
      bin[i + 7] = static_cast<std::uint8_t>(w >> 8), bin[i + 8] = static_cast<std::uint8_t>(w);
      return glb::pack_glb(chunks->json, bin);
    }
  ADD_FAILURE() << "no SOF marker in the sample texture";
  return glb;
}

TEST(GltfUntrusted, ImagesAreCappedFromTheirHeaderBeforeDecoding) {
  const std::string side = error_of(with_texture_size(8193, 16));
  EXPECT_NE(side.find("image 0 is 8193x16: over the limit of 8192 px per side"), std::string::npos) << side;
  EXPECT_LT(peak_growth_mib([&] { (void)decode(with_texture_size(60000, 60000)); }), 32);
  // A header that claims 8192 x 8190 (at both caps) for a 2 kB JPEG: libjpeg fills the missing data with grey, so
  // this is the most a texture can cost: the decoded BGR and RGB copies, then the scene's copy (3 x 192 MiB).
  {
    const Bytes lying = with_texture_size(8192, 8190);  // + the 32x16 image: just under 64 Mpx
    const long mib = peak_growth_mib([&] {
      auto r = decode(lying);
      if (!r.ok() || r->nodes[0].mesh.texture.height != 8190) _exit(3);
    });
    std::printf("8192x8190 texture from a %zu-byte GLB: peak RSS +%ld MiB\n", lying.size(), mib);
    EXPECT_GT(mib, 192);
    EXPECT_LT(mib, 600 + kSanitizerSlackMiB);
  }
  GlbDecodeLimits lim;  // the sample holds two images: 64x48 and 32x16 (3584 px)
  lim.max_image_pixels = 64 * 48 + 32 * 16 - 1;
  EXPECT_NE(error_of(test::plain_sample_glb(), lim)
                .find("image 1 is 32x16: over the limit of 8192 px per side and 3583 px per file"),
            std::string::npos)
      << error_of(test::plain_sample_glb(), lim);
  lim.max_image_pixels = 64 * 48 + 32 * 16;
  auto at_limit = decode(test::plain_sample_glb(), lim);
  EXPECT_TRUE(at_limit.ok()) << at_limit.error().message;
}

TEST(GltfUntrusted, ImageBufferViewPastTheBufferIsRefusedBeforeTinygltfReadsIt) {
  const auto glb = test::edit_glb(test::plain_sample_glb(), [](nlohmann::json& d) {
    d["bufferViews"][d["images"][0]["bufferView"].get<int>()]["byteLength"] = 1 << 24;
  });
  EXPECT_NE(error_of(glb).find("runs past its buffer"), std::string::npos);
}

TEST(GltfUntrusted, MeshoptOutputIsBoundedByTheBudgetAndTheDeclaredSizes) {
  GlbWriteOptions o;  // quantized + meshopt: what rgbdcast writes
  const Bytes glb = encode_glb(test::sample_scene(), o).value();
  ASSERT_TRUE(decode(glb).ok());
  GlbDecodeLimits lim;
  lim.max_meshopt_bytes = 64;
  EXPECT_NE(error_of(glb, lim).find("decoded data over the limit of 64 bytes"), std::string::npos)
      << error_of(glb, lim);
  // A compressed view that claims 2^26 vertices of 16 bytes (1 GiB) is refused before allocating.
  auto chunks = glb::parse_glb(glb.data(), glb.size());
  auto doc = nlohmann::json::parse(chunks->json);
  bool patched = false;
  for (auto& v : doc["bufferViews"])
    if (!patched && v.contains("extensions") && v["extensions"]["EXT_meshopt_compression"]["mode"] == "ATTRIBUTES") {
      auto& ext = v["extensions"]["EXT_meshopt_compression"];
      ext["count"] = 1 << 26;
      ext["byteStride"] = 16;
      v["byteLength"] = std::uint64_t(1) << 30;
      patched = true;
    }
  ASSERT_TRUE(patched);
  const Bytes huge = glb::pack_glb(doc.dump(), chunks->bin);
  EXPECT_NE(error_of(huge).find("over the limit"), std::string::npos) << error_of(huge);
  EXPECT_LT(peak_growth_mib([&] { (void)decode(huge); }), 32);
  // Declared sizes: a view larger than its fallback buffer.
  for (auto& v : doc["bufferViews"])
    if (v.contains("extensions")) {
      v["extensions"]["EXT_meshopt_compression"]["count"] = 4;
      v["byteLength"] = std::uint64_t(1) << 20;
    }
  const Bytes lying = glb::pack_glb(doc.dump(), chunks->bin);
  EXPECT_NE(error_of(lying).find("past its buffer's byteLength"), std::string::npos) << error_of(lying);
}
