// The scene store: atomic writes, listing after a restart, cleanup of what a crash leaves, ids that cannot name a
// path outside the store.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "service/scene_store.h"
#include "tests/common/test_data.h"

namespace fs = std::filesystem;
using namespace rgbdcast::service;

namespace {
std::vector<std::uint8_t> bytes_of(const std::string& s) { return {s.begin(), s.end()}; }
size_t files_in(const std::string& dir) {
  size_t n = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++n;
  return n;
}
}  // namespace

TEST(ServiceStore, IdsAreStrict) {
  const std::string id = new_scene_id();
  EXPECT_EQ(id.size(), 32u);
  EXPECT_TRUE(is_valid_scene_id(id));
  EXPECT_NE(id, new_scene_id());
  for (const char* bad :
       {"", "..", "../../etc/passwd", "0123456789abcdef0123456789abcde", "0123456789abcdef0123456789abcdef0",
        "0123456789ABCDEF0123456789abcdef", "0123456789abcdef0123456789abcde/", "0123456789abcdef0123456789abc%2e"})
    EXPECT_FALSE(is_valid_scene_id(bad)) << bad;
}

TEST(ServiceStore, PutGetListRemoveAndReopen) {
  const std::string dir = rgbdcast::test::temp_dir("store");
  std::string id_a, id_b;
  {
    auto store = SceneStore::open(dir);
    ASSERT_TRUE(store.ok()) << store.error().message;
    auto a = (*store)->put(bytes_of("glTF-A"), {{"triangles", 10}});
    ASSERT_TRUE(a.ok()) << a.error().message;
    auto b = (*store)->put(bytes_of("glTF-BB"), {{"triangles", 20}});
    ASSERT_TRUE(b.ok());
    id_a = a->id;
    id_b = b->id;
    EXPECT_EQ((*store)->count(), 2u);
    EXPECT_EQ((*store)->total_bytes(), 13u);
    EXPECT_EQ(a->metadata()["triangles"], 10);
    EXPECT_EQ(a->triangles, 10u);
    EXPECT_EQ(a->etag, etag_of(bytes_of("glTF-A").data(), 6));
    EXPECT_NE(a->etag, b->etag);
    auto glb = (*store)->read_glb(id_b);
    ASSERT_TRUE(glb.ok());
    EXPECT_EQ(*glb, bytes_of("glTF-BB"));
    EXPECT_FALSE((*store)->get("../" + id_a).has_value());
    EXPECT_EQ((*store)->remove(new_scene_id()).error().code, rgbdcast::ErrorCode::kNotFound);
  }
  {
    auto store = SceneStore::open(dir);  // a restart
    ASSERT_TRUE(store.ok());
    auto list = (*store)->list();
    ASSERT_EQ(list.size(), 2u);
    EXPECT_EQ(list[0].id, id_a);  // oldest first
    EXPECT_EQ(list[1].id, id_b);
    EXPECT_EQ(list[1].metadata()["triangles"], 20);
    EXPECT_EQ(list[1].triangles, 20u);
    EXPECT_EQ(list[1].bytes, 7u);
    EXPECT_TRUE((*store)->cleaned_on_open().empty());
    ASSERT_TRUE((*store)->remove(id_a).ok());
    EXPECT_FALSE((*store)->get(id_a).has_value());
    EXPECT_EQ(files_in(dir + "/scenes"), 2u);  // b's GLB and metadata
  }
  auto store = SceneStore::open(dir);
  ASSERT_TRUE(store.ok());
  EXPECT_EQ((*store)->count(), 1u);
  fs::remove_all(dir);
}

// What an interrupted put() can leave: a temporary file (killed while writing), a GLB without its metadata (killed
// between the two renames). Neither is a scene; both are gone after the restart.
TEST(ServiceStore, CrashLeftoversAreRemovedOnOpen) {
  const std::string dir = rgbdcast::test::temp_dir("store-crash");
  std::string kept;
  {
    auto store = SceneStore::open(dir);
    ASSERT_TRUE(store.ok());
    kept = (*store)->put(bytes_of("whole"), {})->id;
  }
  const std::string scenes = dir + "/scenes";
  const std::string orphan = new_scene_id();
  std::ofstream(scenes + "/.tmp-" + orphan + ".glb-1234abcd") << "half a gl";
  std::ofstream(scenes + "/" + orphan + ".glb") << "a whole GLB without metadata";
  std::ofstream(scenes + "/.tmp-" + orphan + ".json-99") << "{\"id\":";
  std::ofstream(scenes + "/README.txt") << "not ours: left alone";
  auto store = SceneStore::open(dir);
  ASSERT_TRUE(store.ok()) << store.error().message;
  EXPECT_EQ((*store)->count(), 1u);
  EXPECT_TRUE((*store)->get(kept).has_value());
  EXPECT_EQ((*store)->cleaned_on_open().size(), 3u);
  EXPECT_FALSE(fs::exists(scenes + "/" + orphan + ".glb"));
  EXPECT_TRUE(fs::exists(scenes + "/README.txt"));
  EXPECT_EQ(files_in(scenes), 3u);  // kept .glb + .json, README
  fs::remove_all(dir);
}

// A truncated metadata file, or one whose field has the wrong type, is moved to quarantine/ with its GLB;
// the other scenes are served (before: exit 2 on the first, SIGABRT on the second).
TEST(ServiceStore, BadMetadataIsQuarantinedAndTheRestServed) {
  const std::string dir = rgbdcast::test::temp_dir("store-quarantine");
  std::string good, truncated, wrong_type;
  {
    auto store = SceneStore::open(dir);
    ASSERT_TRUE(store.ok());
    good = (*store)->put(bytes_of("glTF-good"), {{"triangles", 1}})->id;
    truncated = (*store)->put(bytes_of("glTF-trunc"), {{"triangles", 2}})->id;
    wrong_type = (*store)->put(bytes_of("glTF-type"), {{"triangles", 3}})->id;
  }
  const std::string scenes = dir + "/scenes/";
  {
    std::ofstream(scenes + truncated + ".json", std::ios::trunc) << "{\"id\": \"" << truncated << "\", \"byt";
    std::ofstream(scenes + wrong_type + ".json", std::ios::trunc)
        << "{\"id\": \"" << wrong_type << "\", \"bytes\": \"nine\", \"etag\": 7, \"created_unix_s\": []}";
  }
  auto store = SceneStore::open(dir);
  ASSERT_TRUE(store.ok()) << store.error().message;
  EXPECT_EQ((*store)->count(), 1u);
  EXPECT_TRUE((*store)->get(good).has_value());
  ASSERT_EQ((*store)->quarantined().size(), 2u);
  for (const std::string& id : {truncated, wrong_type}) {
    EXPECT_TRUE(fs::exists(dir + "/quarantine/" + id + ".json")) << id;
    EXPECT_TRUE(fs::exists(dir + "/quarantine/" + id + ".glb")) << id;
    EXPECT_FALSE(fs::exists(scenes + id + ".glb")) << id;
  }
  EXPECT_EQ(files_in(scenes), 2u);
  fs::remove_all(dir);
}

// The store holds each scene's metadata as compact JSON text (parsed on demand), and the listing's fields copied out
// where they have their types: a restart gives the same text, and a field of another type is left out of the
// listing without refusing the scene (bookkeeping fields of the wrong type still quarantine it, above).
TEST(ServiceStore, MetadataIsHeldAsCompactTextWithTheListingFields) {
  const std::string dir = rgbdcast::test::temp_dir("store-compact");
  const nlohmann::json given = {{"points", 500},
                                {"triangles", 900},
                                {"vertices", 480},
                                {"source", "glb"},
                                {"stages", {{{"name", "voxel"}, {"points", 22474}, {"ms", 25.125}}}}};
  std::string id, text, odd;
  {
    auto store = SceneStore::open(dir);
    ASSERT_TRUE(store.ok());
    auto s = (*store)->put(bytes_of("glTF-compact"), given);
    ASSERT_TRUE(s.ok());
    id = s->id;
    text = s->metadata_json;
    EXPECT_EQ(s->points, 500u);
    EXPECT_EQ(s->triangles, 900u);
    EXPECT_EQ(s->vertices, 480u);
    EXPECT_EQ(s->source, "glb");
    const nlohmann::json back = s->metadata();
    EXPECT_EQ(back["stages"], given["stages"]);
    EXPECT_EQ(back["id"], id);
    EXPECT_EQ(back["bytes"], 12);
    EXPECT_EQ(text, back.dump());  // compact: no indentation
    // The file is the indented form, longer than what is held.
    EXPECT_GT(fs::file_size(dir + "/scenes/" + id + ".json"), text.size());
    odd = (*store)->put(bytes_of("glTF-odd"), {{"points", -3}, {"triangles", "many"}, {"source", 7}})->id;
  }
  auto store = SceneStore::open(dir);  // a restart reads the indented file back into the same compact text
  ASSERT_TRUE(store.ok());
  auto s = (*store)->get(id);
  ASSERT_TRUE(s.has_value());
  EXPECT_EQ(s->metadata_json, text);
  EXPECT_EQ(s->triangles, 900u);
  auto o = (*store)->get(odd);
  ASSERT_TRUE(o.has_value());
  EXPECT_FALSE(o->points.has_value());
  EXPECT_FALSE(o->triangles.has_value());
  EXPECT_FALSE(o->source.has_value());
  EXPECT_EQ(o->metadata()["triangles"], "many");
  fs::remove_all(dir);
}
