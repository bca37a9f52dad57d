// GET /v1/scenes/{id}/model.glb?flavor=compact|compat|draco on the real `rgbdcast serve`: a compact GLB of TUM fr1/xyz
// frame 0 (made by `rgbdcast reduce`) is uploaded; its compat flavour is converted once, cached (X-Flavor-Cache),
// has its own ETag (304 on If-None-Match), holds the same scene in plain floats; compact is the stored file; an
// unknown flavour is 400 with a JSON body; a deleted scene's flavours are gone. draco (KHR_draco_mesh_compression) is
// converted once and cached like compat; a Draco GLB uploaded is decoded (untrusted) and stored; a forged one is 422.
// Eigen (through gltf_io.h) before httplib.h: glibc's resolv.h, which httplib includes, defines _res, a name Eigen
// uses.
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

// TUM fr1/xyz frame 0 reduced by the real command line (extra: more reduce options), as GLB bytes.
std::string reduce_tum_frame(const std::string& dir, const std::string& extra) {
  const std::string glb_path = dir + "/tum-compact.glb";
  const auto reduced = test::run_command(test::rgbdcast_binary() + " reduce --input " + test::data_path(kTum) +
                                         " --frame 0 " + extra + " --out " + glb_path);
  EXPECT_EQ(reduced.exit_code, 0) << reduced.err;
  return test::read_file(glb_path);
}

// POSTs a GLB to /v1/scenes; the new scene's id, or "" (with a test failure).
std::string upload(httplib::Client& c, const std::string& glb) {
  auto up = c.Post("/v1/scenes", glb, "model/gltf-binary");
  EXPECT_TRUE(up && up->status == 201) << (up ? up->body : "no response");
  return up && up->status == 201 ? json::parse(up->body)["id"].get<std::string>() : "";
}

TEST(ServiceModelFlavors, CompatIsConvertedOnceCachedAndHasItsOwnEtag) {
  REQUIRE_DATA(kTum);
  const std::string dir = test::temp_dir("model-flavors");
  const std::string compact = reduce_tum_frame(dir, "--preset paper");

  test::ServerProcess server;
  std::string error;
  ASSERT_TRUE(server.start(dir + "/data", {}, &error)) << error;
  httplib::Client c("127.0.0.1", server.port());
  c.set_read_timeout(60, 0);
  const std::string id = upload(c, compact);
  ASSERT_FALSE(id.empty());
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

TEST(ServiceModelFlavors, DracoIsConvertedOnceAndADracoUploadIsStoredAndServed) {
  REQUIRE_DATA(kTum);
  const std::string dir = test::temp_dir("model-flavors-draco");
  const std::string compact = reduce_tum_frame(dir, "--preset realtime --geometry-codec meshopt");
  test::ServerProcess server;
  std::string error;
  ASSERT_TRUE(server.start(dir + "/data", {}, &error)) << error;
  httplib::Client c("127.0.0.1", server.port());
  c.set_read_timeout(60, 0);
  const std::string base = "/v1/scenes/" + upload(c, compact) + "/model.glb";

  auto draco = c.Get((base + "?flavor=draco").c_str());
  ASSERT_TRUE(draco);
  ASSERT_EQ(draco->status, 200) << draco->body;
  EXPECT_EQ(draco->get_header_value("X-Flavor-Cache"), "miss");
  EXPECT_EQ(glb_json(draco->body)["extensionsRequired"], json::array({"KHR_draco_mesh_compression"}));
  EXPECT_LT(draco->body.size(), compact.size());
  std::printf("[ flavors ] realtime TUM frame 0: compact (meshopt) %zu bytes, draco %zu bytes\n", compact.size(),
              draco->body.size());
  auto again = c.Get((base + "?flavor=draco").c_str());
  ASSERT_TRUE(again && again->status == 200);
  EXPECT_EQ(again->get_header_value("X-Flavor-Cache"), "hit");
  auto a = decode_glb(reinterpret_cast<const std::uint8_t*>(compact.data()), compact.size());
  auto b = decode_glb(reinterpret_cast<const std::uint8_t*>(draco->body.data()), draco->body.size());
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(b->nodes[0].mesh.triangle_count(), a->nodes[0].mesh.triangle_count());

  // The Draco file uploaded: decoded as untrusted input, stored; its draco flavour is the stored file.
  const std::string draco_id = upload(c, draco->body);
  ASSERT_FALSE(draco_id.empty());
  const std::string draco_base = "/v1/scenes/" + draco_id + "/model.glb";
  auto stored = c.Get((draco_base + "?flavor=draco").c_str());
  ASSERT_TRUE(stored && stored->status == 200);
  EXPECT_EQ(stored->get_header_value("X-Flavor-Cache"), "stored");
  auto compat = c.Get((draco_base + "?flavor=compat").c_str());
  ASSERT_TRUE(compat && compat->status == 200);
  EXPECT_FALSE(glb_json(compat->body).contains("extensionsRequired"));

  // A Draco GLB whose indices accessor declares more triangles than its Draco data: 422 with a JSON body.
  auto chunks = glb::parse_glb(reinterpret_cast<const std::uint8_t*>(draco->body.data()), draco->body.size());
  ASSERT_TRUE(chunks.ok());
  json doc = json::parse(chunks->json);
  const size_t ind = doc["meshes"][0]["primitives"][0]["indices"];
  doc["accessors"][ind]["count"] = doc["accessors"][ind]["count"].get<size_t>() + 300;
  const auto forged = glb::pack_glb(doc.dump(), chunks->bin);
  auto refused = c.Post("/v1/scenes", std::string(forged.begin(), forged.end()), "model/gltf-binary");
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->status, 422) << refused->body;
  EXPECT_NE(refused->body.find("draco"), std::string::npos) << refused->body;
  EXPECT_TRUE(json::parse(refused->body, nullptr, false).is_object()) << refused->body;
  server.stop();
  fs::remove_all(dir);
}

}  // namespace
