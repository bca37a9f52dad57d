// decode_glb on hostile input: every truncation of a valid file, random byte flips, mangled JSON. The reader must
// answer with a Scene or a kInvalidInput error; never crash, hang or throw. (Run under ASan/UBSan to be thorough.)
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <random>

#include "gltf/glb_container.h"
#include "gltf/gltf_io.h"
#include "tests/gltf/sample_scenes.h"

using namespace rgbdcast;

namespace {

std::vector<std::uint8_t> sample_glb(bool quantize, bool meshopt) {
  GlbWriteOptions o;
  o.quantize = quantize;
  o.meshopt = meshopt;
  auto glb = encode_glb(test::sample_scene(), o);
  EXPECT_TRUE(glb.ok());
  return glb.value();
}

}  // namespace

TEST(GltfHostile, EveryTruncationIsAClearError) {
  for (bool meshopt : {false, true}) {
    const auto glb = sample_glb(true, meshopt);
    ASSERT_TRUE(decode_glb(glb.data(), glb.size()).ok());
    int errors = 0;
    // Every offset in the header and JSON, then a stride through the binary chunk.
    for (size_t n = 0; n < glb.size(); n += (n < 4096 ? 1 : 97)) {
      auto r = decode_glb(glb.data(), n);
      ASSERT_FALSE(r.ok()) << "truncated to " << n << " of " << glb.size() << " bytes decoded";
      EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput) << r.error().message;
      EXPECT_EQ(r.error().message.find('\n'), std::string::npos) << "one-line message";
      ++errors;
    }
    EXPECT_GT(errors, 1000);
  }
  EXPECT_EQ(decode_glb(nullptr, 0).error().code, ErrorCode::kInvalidInput);
}

// Truncations that keep the container consistent (header and chunk lengths rewritten to the cut), so that the
// checks behind the container (JSON parse, bufferView and accessor ranges, image decoding) are the ones hit.
TEST(GltfHostile, TruncatedChunksWithConsistentLengthsAreErrors) {
  for (bool meshopt : {false, true}) {
    const auto glb = sample_glb(true, meshopt);
    auto chunks = glb::parse_glb(glb.data(), glb.size());
    ASSERT_TRUE(chunks.ok());
    int rejected = 0, total = 0;
    // pack_glb pads the chunk to 4 bytes again, so cuts inside the last 4 bytes give back the same file.
    for (size_t n = 0; ((n + 3) & ~size_t(3)) < chunks->bin.size(); n += 7) {
      std::vector<std::uint8_t> bin(chunks->bin.begin(), chunks->bin.begin() + n);
      const auto bytes = glb::pack_glb(chunks->json, bin);
      auto r = decode_glb(bytes.data(), bytes.size());
      ++total;
      if (r.ok())
        std::printf("meshopt=%d: BIN cut to %zu of %zu bytes still decodes\n", meshopt, n, chunks->bin.size());
      if (!r.ok()) {
        ++rejected;
        EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput) << r.error().message;
      }
    }
    EXPECT_EQ(rejected, total) << "a BIN chunk shorter than the buffer it holds must be rejected";
    const size_t json_end = chunks->json.find_last_of('}');  // trailing padding spaces may go
    for (size_t n = 0; n < json_end; n += 3) {
      const auto bytes = glb::pack_glb(chunks->json.substr(0, n), chunks->bin);
      auto r = decode_glb(bytes.data(), bytes.size());
      ASSERT_FALSE(r.ok()) << "JSON cut at " << n;
      EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput);
    }
  }
}

TEST(GltfHostile, RandomByteFlipsNeverCrash) {
  std::mt19937 rng(12345);
  for (bool meshopt : {false, true}) {
    const auto glb = sample_glb(true, meshopt);
    int ok = 0, failed = 0;
    // RGBDCAST_FUZZ_TRIALS raises the count for a longer run (e.g. under ASan/UBSan).
    const int trials = std::getenv("RGBDCAST_FUZZ_TRIALS") ? std::atoi(std::getenv("RGBDCAST_FUZZ_TRIALS")) : 1500;
    for (int trial = 0; trial < trials; ++trial) {
      auto bad = glb;
      const int flips = 1 + trial % 8;
      for (int f = 0; f < flips; ++f) {
        // Half the flips land in the first 4 KiB (header + JSON), where structure lives.
        const size_t span = (f % 2 == 0) ? std::min<size_t>(4096, bad.size()) : bad.size();
        bad[rng() % span] ^= static_cast<std::uint8_t>(1u << (rng() % 8));
      }
      auto r = decode_glb(bad.data(), bad.size());
      if (r.ok()) {
        ++ok;
        // Whatever was accepted is internally consistent.
        for (const auto& n : r->nodes) {
          for (auto i : n.mesh.indices) ASSERT_LT(i, n.mesh.positions.size());
          if (!n.mesh.texture.empty()) {
            ASSERT_EQ(n.mesh.texture.data.size(), size_t(n.mesh.texture.width) * n.mesh.texture.height * 3);
          }
        }
      } else {
        ++failed;
        EXPECT_TRUE(r.error().code == ErrorCode::kInvalidInput || r.error().code == ErrorCode::kEmpty)
            << r.error().message;
      }
    }
    std::printf("meshopt=%d: %d flipped files decoded, %d rejected\n", meshopt, ok, failed);
    EXPECT_GT(failed, 0);
  }
}

TEST(GltfHostile, MangledDocumentsAreErrors) {
  const auto glb = sample_glb(true, false);
  auto chunks = glb::parse_glb(glb.data(), glb.size());
  ASSERT_TRUE(chunks.ok());
  const auto doc = nlohmann::json::parse(chunks->json);
  auto decode_with = [&](const nlohmann::json& d) {
    const auto bytes = glb::pack_glb(d.dump(), chunks->bin);
    return decode_glb(bytes.data(), bytes.size());
  };
  std::vector<std::pair<std::string, nlohmann::json>> cases;
  auto with = [&](const char* name, auto edit) {
    nlohmann::json d = doc;
    edit(d);
    cases.emplace_back(name, d);
  };
  with("accessor count huge", [](auto& d) { d["accessors"][0]["count"] = 4000000000u; });
  with("accessor offset past view", [](auto& d) { d["accessors"][0]["byteOffset"] = 1 << 30; });
  with("bufferView past buffer", [](auto& d) { d["bufferViews"][0]["byteLength"] = 1 << 30; });
  with("bufferView index", [](auto& d) { d["accessors"][0]["bufferView"] = 999; });
  with("buffer index", [](auto& d) { d["bufferViews"][0]["buffer"] = 7; });
  with("node cycle", [](auto& d) { d["nodes"][0]["children"] = nlohmann::json::array({0}); });
  with("child out of range", [](auto& d) { d["nodes"][0]["children"] = nlohmann::json::array({12345}); });
  with("mesh index", [](auto& d) { d["nodes"][0]["mesh"] = 99; });
  with("material index", [](auto& d) { d["meshes"][0]["primitives"][0]["material"] = 99; });
  with("texture source", [](auto& d) { d["textures"][0]["source"] = 99; });
  with("image view", [](auto& d) { d["images"][0]["bufferView"] = 999; });
  with("indices out of range", [](auto& d) { d["meshes"][0]["primitives"][0]["indices"] = 0; });
  with("wrong type", [](auto& d) { d["accessors"][0]["type"] = "MAT4"; });
  with("string where number", [](auto& d) { d["accessors"][0]["count"] = "many"; });
  with("required extension",
       [](auto& d) { d["extensionsRequired"] = nlohmann::json::array({"KHR_draco_mesh_compression"}); });
  with("not an object", [](auto& d) { d = nlohmann::json::array({1, 2}); });
  for (const auto& [name, d] : cases) {
    auto r = decode_with(d);
    EXPECT_FALSE(r.ok()) << name;
    if (!r.ok()) {
      EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput) << name << ": " << r.error().message;
    }
  }
  // Not JSON at all.
  {
    const auto bytes = glb::pack_glb("{\"asset\":", chunks->bin);
    EXPECT_EQ(decode_glb(bytes.data(), bytes.size()).error().code, ErrorCode::kInvalidInput);
  }
  // A JPEG whose frame header claims 60000 x 60000 pixels (10 GB decoded) is refused before decoding.
  {
    auto bin = chunks->bin;
    const auto& view = doc["bufferViews"][doc["images"][0]["bufferView"].get<int>()];
    const size_t off = view.value("byteOffset", size_t(0)), len = view["byteLength"].get<size_t>();
    bool patched = false;
    for (size_t i = off; i + 9 < off + len && !patched; ++i)
      if (bin[i] == 0xFF && (bin[i + 1] == 0xC0 || bin[i + 1] == 0xC2)) {
        bin[i + 5] = 0xEA, bin[i + 6] = 0x60, bin[i + 7] = 0xEA, bin[i + 8] = 0x60;
        patched = true;
      }
    ASSERT_TRUE(patched);
    const auto bytes = glb::pack_glb(chunks->json, bin);
    auto r = decode_glb(bytes.data(), bytes.size());
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput);
    EXPECT_NE(r.error().message.find("8192"), std::string::npos) << r.error().message;
  }
}
