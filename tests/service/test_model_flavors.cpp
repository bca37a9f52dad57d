// GET /v1/scenes/{id}/model.glb?flavor=compact|compat on the real `rgbdcast serve`: a compact GLB of TUM fr1/xyz
// frame 0 (made by `rgbdcast reduce`) is uploaded; its compat flavour is converted once, cached (X-Flavor-Cache),
// has its own ETag (304 on If-None-Match), holds the same scene in plain floats; compact is the stored file; an
// unknown flavour is 400 with a JSON body; a deleted scene's flavours are gone.
// Eigen (through gltf_io.h) before httplib.h: glibc's resolv.h, which httplib includes, defines _res, a name Eigen uses.
#include "gltf/glb_container.h"
#include "gltf/gltf_io.h"

#include <httplib.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "tests/common/test_data.h"
#include "tests/service/server_process.h"

namespace fs = std::filesystem;
using nlohmann::json;
using namespace rgbdcast;

namespace {

constexpr const char* kTum = "tum/rgbd_dataset_freiburg1_xyz";

json glb_json(const std::string& body) {
  auto chunks = glb::parse_glb(reinterpret_cast<const std::uint8_t*>(body.data()), body.size());
  return chunks ? json::parse(chunks->json, nullptr, false) : json();
}

TEST(ServiceModelFlavors, CompatIsConvertedOnceCachedAndHasItsOwnEtag) {
  REQUIRE_DATA(kTum);
  const std::string dir = test::temp_dir("model-flavors");
  const std::string glb_path = dir + "/tum-compact.glb";
  const auto reduced = test::run_command(test::rgbdcast_binary() + " reduce --input " + test::data_path(kTum) +
                                         " --frame 0 --out " + glb_path);
  ASSERT_EQ(reduced.exit_code, 0) << reduced.err;
  const std::string compact = test::read_file(glb_path);

  test::ServerProcess server;
  std::string error;
  ASSERT_TRUE(server.start(dir + "/data", {}, &error)) << error;
  httplib::Client c("127.0.0.1", server.port());
  c.set_read_timeout(60, 0);
  auto up = c.Post("/v1/scenes", compact, "model/gltf-binary");
  ASSERT_TRUE(up);
  ASSERT_EQ(up->status, 201) << up->body;
  const std::string id = json::parse(up->body)["id"];
  const std::string base = "/v1/scenes/" + id + "/model.glb";

  auto stored = c.Get(base.c_str());
  ASSERT_TRUE(stored && stored->status == 200);
  const std::string stored_etag = stored->get_header_value("ETag");

  auto first = c.Get((base + "?flavor=compat").c_str());
  ASSERT_TRUE(first);
  ASSERT_EQ(first->status, 200) << first->body;
  EXPECT_EQ(first->get_header_value("Content-Type"), "model/gltf-binary");
  EXPECT_EQ(first->get_header_value("X-Flavor-Cache"), "miss");
  const std::string compat_etag = first->get_header_value("ETag");
  EXPECT_FALSE(compat_etag.empty());
  EXPECT_NE(compat_etag, stored_etag);
  EXPECT_NE(first->get_header_value("Content-Disposition").find(id + "-compat.glb"), std::string::npos);

  // The same scene, in plain floats.
  auto a = decode_glb(reinterpret_cast<const std::uint8_t*>(compact.data()), compact.size());
  auto b = decode_glb(reinterpret_cast<const std::uint8_t*>(first->body.data()), first->body.size());
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_EQ(b->nodes.size(), a->nodes.size());
  EXPECT_EQ(b->nodes[0].mesh.positions.size(), a->nodes[0].mesh.positions.size());
  EXPECT_EQ(b->nodes[0].mesh.triangle_count(), a->nodes[0].mesh.triangle_count());
  EXPECT_EQ(b->cameras.size(), a->cameras.size());
  const json doc = glb_json(first->body);
  EXPECT_FALSE(doc.contains("extensionsRequired")) << doc.dump().substr(0, 400);
  std::printf("[ flavors ] stored (compact) %zu bytes, compat %zu bytes\n", compact.size(), first->body.size());
  EXPECT_GT(first->body.size(), compact.size());

  auto again = c.Get((base + "?flavor=compat").c_str());
  ASSERT_TRUE(again && again->status == 200);
  EXPECT_EQ(again->get_header_value("X-Flavor-Cache"), "hit");
  EXPECT_EQ(again->get_header_value("ETag"), compat_etag);
  EXPECT_TRUE(again->body == first->body);

  auto not_modified = c.Get((base + "?flavor=compat").c_str(), {{"If-None-Match", compat_etag}});
  ASSERT_TRUE(not_modified);
  EXPECT_EQ(not_modified->status, 304);
  auto stale = c.Get((base + "?flavor=compat").c_str(), {{"If-None-Match", stored_etag}});
  ASSERT_TRUE(stale);
  EXPECT_EQ(stale->status, 200);  // the stored file's ETag is not the compat file's

  // compact: the stored file itself (it already is compact), with the stored file's ETag.
  auto as_compact = c.Get((base + "?flavor=compact").c_str());
  ASSERT_TRUE(as_compact && as_compact->status == 200);
  EXPECT_EQ(as_compact->get_header_value("ETag"), stored_etag);
  EXPECT_EQ(as_compact->get_header_value("X-Flavor-Cache"), "stored");
  EXPECT_TRUE(as_compact->body == compact);

  for (const char* bad : {"?flavor=tiny", "?flavor=", "?flavor=compat&flavor=compact"}) {
    auto r = c.Get((base + std::string(bad)).c_str());
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 400) << bad << ": " << r->body;
    EXPECT_NE(r->get_header_value("Content-Type").find("application/json"), std::string::npos) << bad;
    const json body = json::parse(r->body, nullptr, false);
    ASSERT_TRUE(body.is_object()) << r->body;
    EXPECT_EQ(body["error"], "bad_request") << r->body;
  }
  auto unknown = c.Get((base + "?flavor=tiny").c_str());
  EXPECT_NE(unknown->body.find("compat"), std::string::npos) << unknown->body;

  // A scene uploaded as compat: its compact flavour is converted (meshopt), its compat flavour is a file of its own.
  auto up_compat = c.Post("/v1/scenes", first->body, "model/gltf-binary");
  ASSERT_TRUE(up_compat);
  ASSERT_EQ(up_compat->status, 201) << up_compat->body;
  const std::string compat_id = json::parse(up_compat->body)["id"];
  auto packed = c.Get(("/v1/scenes/" + compat_id + "/model.glb?flavor=compact").c_str());
  ASSERT_TRUE(packed && packed->status == 200);
  EXPECT_EQ(packed->get_header_value("X-Flavor-Cache"), "miss");
  EXPECT_NE(glb_json(packed->body).dump().find("EXT_meshopt_compression"), std::string::npos);
  EXPECT_LT(packed->body.size(), first->body.size());

  auto del = c.Delete(("/v1/scenes/" + id).c_str());
  ASSERT_TRUE(del);
  EXPECT_EQ(del->status, 204);
  auto gone = c.Get((base + "?flavor=compat").c_str());
  ASSERT_TRUE(gone);
  EXPECT_EQ(gone->status, 404);
  server.stop();
  fs::remove_all(dir);
}

}  // namespace
