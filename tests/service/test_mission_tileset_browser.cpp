// A mission's live 3D Tiles tileset in a real 3D Tiles client: three.js 0.187 with 3DTilesRendererJS
// (tools/package.json) in Debian's headless Chromium. The real `rgbdcast serve` gets a few real keyframes (TUM frames
// reduced by the CLI); once its background worker has put every keyframe into the leaves, tools/tiles_view.html
// loads tileset.json and its tile GLBs (EXT_meshopt_compression, KHR_mesh_quantization, JPEG) through TilesRenderer,
// looks at the root bounding volume and reads the pixels back. The page and its modules come from tools/ and
// tools/node_modules on the test's loopback server, which relays /v1/ to serve: one origin, nothing from another host.
// Eigen (gltf_io.h) before httplib.h: a macro of the headers httplib pulls in breaks Eigen's product kernels.
#include "gltf/gltf_io.h"

#include <gtest/gtest.h>
#include <httplib.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <set>
#include <thread>

#include <nlohmann/json.hpp>

#include "tests/common/test_data.h"
#include "tests/gltf/headless_chromium.h"
#include "tests/service/mission_keyframes.h"
#include "tests/service/server_process.h"

using nlohmann::json;
namespace fs = std::filesystem;

namespace {

void content_uris(const json& tile, std::vector<std::string>* uris) {
  if (tile.contains("content")) uris->push_back(tile["content"]["uri"]);
  for (const auto& child : tile.value("children", json::array())) content_uris(child, uris);
}

// Whether every tile below the root has content (none is stale).
bool all_fresh(const json& tile, bool root) {
  if (!root && !tile.contains("content")) return false;
  for (const auto& child : tile.value("children", json::array()))
    if (!all_fresh(child, false)) return false;
  return true;
}

// Triangles in the tileset's leaves (level 0 tiles) once the leaf of keyframe `newest` is among them; 0 before, or
// when a tile was replaced between the two reads.
size_t leaf_triangles(httplib::Client& c, const std::string& mission, const json& tileset, int newest) {
  std::vector<std::string> uris;
  content_uris(tileset["root"], &uris);
  const std::string suffix = "_" + std::to_string(newest) + ".v";
  if (std::none_of(uris.begin(), uris.end(), [&](const std::string& uri) {
        return uri.rfind("tiles/0_", 0) == 0 && uri.find(suffix) != std::string::npos;
      }))
    return 0;
  size_t n = 0;
  for (const auto& uri : uris) {
    if (uri.rfind("tiles/0_", 0) != 0) continue;
    auto r = c.Get(("/v1/missions/" + mission + "/" + uri).c_str());
    if (!r || r->status != 200) return 0;
    auto scene = rgbdcast::decode_glb(reinterpret_cast<const std::uint8_t*>(r->body.data()), r->body.size());
    if (scene) n += scene->triangle_count();
  }
  return n;
}

std::string base64_decode(const std::string& in) {
  auto value = [](char ch) -> int {
    if (ch >= 'A' && ch <= 'Z') return ch - 'A';
    if (ch >= 'a' && ch <= 'z') return ch - 'a' + 26;
    if (ch >= '0' && ch <= '9') return ch - '0' + 52;
    if (ch == '+') return 62;
    if (ch == '/') return 63;
    return -1;
  };
  std::string out;
  int bits = 0, acc = 0;
  for (char ch : in) {
    const int v = value(ch);
    if (v < 0) continue;
    acc = (acc << 6) | v;
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<char>((acc >> bits) & 0xff));
    }
  }
  return out;
}

TEST(MissionTilesetBrowser, TilesRendererLoadsTheTilesetAndDrawsIt) {
  REQUIRE_DATA(rgbdcast::test::kMissionExcerpt);
  const std::string chromium = rgbdcast::test::find_chromium();
  if (chromium.empty()) RGBDCAST_MISSING_PREREQUISITE("no chromium (scripts/setup.sh installs it)");
  for (const char* module :
       {"tools/node_modules/three/build/three.module.js", "tools/node_modules/3d-tiles-renderer/build/index.three.js"})
    if (!fs::exists(rgbdcast::test::source_path(module)))
      RGBDCAST_MISSING_PREREQUISITE(std::string(module) + " missing (scripts/setup.sh installs tools/package.json)");
  std::string error;
  const auto k = rgbdcast::test::mission_keyframes({0, 40, 80}, &error);
  ASSERT_EQ(k.size(), 3u) << error;
  const std::string dir = rgbdcast::test::temp_dir("mission-tileset-browser");
  rgbdcast::test::ServerProcess server;
  ASSERT_TRUE(server.start(dir + "/data", {}, &error)) << error;
  httplib::Client c("127.0.0.1", server.port());
  c.set_read_timeout(120, 0);
  size_t posted = 0, posted_bytes = 0;
  for (int seq = 0; seq < 3; ++seq) {
    const auto& f = k[static_cast<size_t>(seq)];
    const std::string path = "/v1/missions/floor/keyframes?seq=" + std::to_string(seq) + "&pose=" + f.pose;
    auto r = c.Post(path.c_str(), f.glb, "model/gltf-binary");
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 201) << r->body;
    posted += json::parse(r->body)["triangles"].get<size_t>();
    posted_bytes += f.glb.size();
  }

  // The tileset is built in the background: wait (60 s at most) until its leaves hold every keyframe (the newest one
  // whole, the older ones less what it saw again) and no tile is stale (every tile below the root has content), so
  // the browser reads this version.
  json tileset;
  size_t in_leaves = 0;
  const auto t0 = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - t0 < std::chrono::seconds(60)) {
    auto r = c.Get("/v1/missions/floor/tileset.json");
    ASSERT_TRUE(r && r->status == 200);
    tileset = json::parse(r->body);
    if ((in_leaves = leaf_triangles(c, "floor", tileset, 2)) > 0 && all_fresh(tileset["root"], true)) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  ASSERT_GT(in_leaves, 0u) << "the tileset did not take every keyframe within 60 s: " << tileset.dump();
  EXPECT_LE(in_leaves, posted);
  ASSERT_TRUE(all_fresh(tileset["root"], true)) << "stale tiles after 60 s: " << tileset.dump();
  const double built_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::vector<std::string> uris;
  content_uris(tileset["root"], &uris);
  size_t tile_bytes = 0;
  for (const auto& uri : uris) tile_bytes += c.Get(("/v1/missions/floor/" + uri).c_str())->body.size();

  // Two views from the same camera: TilesRenderer's default error target (16 px), then 1 px, which refines to the
  // textured leaves.
  const int w = 480, h = 360;
  const auto post = rgbdcast::test::run_tools_page(
      chromium,
      "tiles_view.html?tileset=/v1/missions/floor/tileset.json&w=480&h=360&error_targets=16,1&timeout_ms=90000", {},
      dir, "tiles", w, h, 120000, {{"/v1/", server.port()}});
  ASSERT_TRUE(post.reported) << "the page reported nothing; " << rgbdcast::test::read_file(post.log).substr(0, 3000);
  ASSERT_TRUE(post.ok) << post.body << "\n" << rgbdcast::test::read_file(post.log).substr(0, 3000);
  json r = json::parse(post.body, nullptr, false);
  ASSERT_TRUE(r.is_object() && r["views"].size() == 2) << post.body.substr(0, 500);
  std::vector<std::string> images;
  for (auto& v : r["views"]) {
    images.push_back(dir + "/tiles-error-target-" + std::to_string(v["errorTarget"].get<int>()) + ".png");
    const std::string data_url = v.value("png", "");
    std::ofstream(images.back(), std::ios::binary) << base64_decode(data_url.substr(data_url.find(',') + 1));
    v.erase("png");
  }
  std::cout << "tileset of 3 keyframes (" << posted << " triangles, " << posted_bytes << " posted bytes): version "
            << tileset["asset"].value("tilesetVersion", "?") << ", " << uris.size() << " tiles, " << tile_bytes
            << " tile bytes, built in " << built_s << " s\nin the browser (" << post.ms / 1000.0
            << " s from launch): " << r.dump() << "\nimages " << images[0] << " " << images[1] << "\n";

  EXPECT_EQ(r["pixels"].get<int>(), w * h);
  EXPECT_EQ(r["tilesetVersion"], tileset["asset"]["tilesetVersion"]);
  const std::set<std::string> known(uris.begin(), uris.end());
  for (size_t i = 0; i < 2; ++i) {
    const json& v = r["views"][i];
    EXPECT_GT(v["tilesLoaded"].get<int>(), 0) << v;
    EXPECT_GT(v["visibleTiles"].get<int>(), 0) << v;
    EXPECT_GT(v["triangles"].get<double>(), 0.0) << v;
    EXPECT_GT(v["drawn"].get<int>(), w * h / 20) << "a twentieth of the view or less drawn: see " << images[i];
    // What the client drew are tiles of the tileset the test read.
    for (const auto& uri : v["visibleUris"]) {
      const std::string u = uri.get<std::string>();
      EXPECT_TRUE(known.count(u.substr(u.find("tiles/")))) << u;
    }
  }
  // At 1 px the client shows the leaves, which carry every triangle the tileset's leaves hold and the keyframes'
  // texture atlas.
  const json& fine = r["views"][1];
  for (const auto& uri : fine["visibleUris"])
    EXPECT_NE(uri.get<std::string>().find("tiles/0_"), std::string::npos) << "not a leaf: " << uri;
  EXPECT_EQ(fine["triangles"].get<size_t>(), in_leaves);
  EXPECT_GT(fine["textured"].get<int>(), 0);
  EXPECT_GE(fine["drawn"].get<int>(), r["views"][0]["drawn"].get<int>() * 9 / 10);
  server.stop();
}

}  // namespace
