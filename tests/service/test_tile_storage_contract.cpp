// The tile storage contract (tiles/tile_storage.h), run by the same cases on both implementations: the directory
// store and PostgreSQL's rows (pgstore/pg_tile_storage.h), the latter on a throwaway server this program starts
// (tests/common/postgres_server.h), one fresh database per test. Then what only the shared database does: a second
// replica's storage with an empty cache reads every tile from the rows, a file of a version above the committed one
// (another replica's update under way) survives a collection, and a mission's removal takes its tiles along.
#include <gtest/gtest.h>

#include <filesystem>

#include "base/atomic_file.h"

#include "pgstore/pg_connection.h"
#include "pgstore/pg_tile_storage.h"
#include "tests/common/postgres_server.h"
#include "tests/common/test_data.h"
#include "tests/common/typed_test_names.h"
#include "tiles/tile_storage.h"

using namespace rgbdcast;
using rgbdcast::tiles::TileCommit;
using rgbdcast::tiles::TileStorage;

namespace {

constexpr const char* kMission = "m1";

struct DirectoryBackend {
  static constexpr const char* kName = "Directory";
  static constexpr bool kShared = false;
  Status prepare() {
    dir = test::temp_dir("tile-storage");
    return ok_status();
  }
  // Every storage of the mission is the same folder (`cache` is the directory store's only copy).
  Result<std::unique_ptr<TileStorage>> open(const std::string& /*cache*/) {
    return tiles::directory_tile_storage(dir + "/tiles");
  }
  Status remove_mission() { return ok_status(); }
  std::string dir;
};

struct PostgresBackend {
  static constexpr const char* kName = "Postgres";
  static constexpr bool kShared = true;
  Status prepare() {
    auto db = test::fresh_database();
    if (!db) return db.error();
    uri = *db;
    dir = test::temp_dir("tile-storage-pg");
    auto stores = pgstore::PgTileStores::open(uri, 2);
    if (!stores) return stores.error();
    this->stores = std::move(*stores);
    // Tiles belong to a mission (their rows go with it).
    return sql("INSERT INTO missions (name, created_change) VALUES ('" + std::string(kMission) + "', 0)");
  }
  Result<std::unique_ptr<TileStorage>> open(const std::string& cache) {
    return stores->storage(kMission, dir + "/" + cache);
  }
  Status remove_mission() { return sql("DELETE FROM missions WHERE name = '" + std::string(kMission) + "'"); }
  Status sql(const std::string& statement) {
    auto conn = pgstore::PgConnection::connect(uri);
    if (!conn) return conn.error();
    return (*conn)->run(statement);
  }
  std::string uri, dir;
  std::unique_ptr<pgstore::PgTileStores> stores;
};

template <class Backend>
class TileStorageContract : public ::testing::Test {
 protected:
  void SetUp() override {
    auto st = backend.prepare();
    if (!st) RGBDCAST_MISSING_PREREQUISITE("tile storage backend: " + st.error().message);
  }
  std::unique_ptr<TileStorage> open(const std::string& cache = "a") {
    auto s = backend.open(cache);
    EXPECT_TRUE(s) << s.error().message;
    return s ? std::move(*s) : nullptr;
  }
  Backend backend;
};

using Backends = ::testing::Types<DirectoryBackend, PostgresBackend>;
TYPED_TEST_SUITE(TileStorageContract, Backends, test::SelfNamedTypes);

std::vector<std::uint8_t> bytes(const std::string& s) { return {s.begin(), s.end()}; }

// A commit of `version` whose record names `named` with the sizes `s` stores for them (0 for a file not stored).
TileCommit record(const TileStorage& s, std::uint64_t version, const std::set<std::string>& named,
                  std::set<std::string> retained = {}, std::set<std::string> garbage = {}) {
  TileCommit c;
  c.version = version;
  c.record = bytes("{\"version\":" + std::to_string(version) + "}");
  for (const auto& f : named) {
    auto stored = s.read_tile(f);
    c.named[f] = stored ? stored->size() : 0;
  }
  c.retained = std::move(retained);
  c.garbage = std::move(garbage);
  return c;
}

bool stored(const TileStorage& s, const std::string& file) { return static_cast<bool>(s.read_tile(file)); }

TYPED_TEST(TileStorageContract, TilesAndTheirRecordAreReadBackAsCommitted) {
  auto s = this->open();
  ASSERT_TRUE(s);
  auto none = s->read_record();
  ASSERT_TRUE(none) << none.error().message;
  EXPECT_FALSE(*none);
  EXPECT_EQ(*s->committed_version(), 0u);
  ASSERT_TRUE(s->write_tile("0_0_0_1.v1.glb", bytes("leaf one")));
  ASSERT_TRUE(s->write_tile("1_0_0.v1.glb", bytes("inner one")));
  auto committed = s->commit(record(*s, 1, {"0_0_0_1.v1.glb", "1_0_0.v1.glb"}));
  ASSERT_TRUE(committed) << committed.error().message;
  EXPECT_TRUE(*committed);
  auto r = s->read_record();
  ASSERT_TRUE(r && *r);
  EXPECT_EQ((*r)->version, 1u);
  EXPECT_EQ((*r)->bytes, bytes("{\"version\":1}"));
  EXPECT_EQ(*s->committed_version(), 1u);
  EXPECT_EQ(*s->read_tile("1_0_0.v1.glb"), bytes("inner one"));
  auto path = s->local_file("0_0_0_1.v1.glb");
  ASSERT_TRUE(path) << path.error().message;
  EXPECT_EQ(*read_file_bytes(*path, 1 << 20), bytes("leaf one"));
  EXPECT_EQ(s->read_tile("2_0_0.v1.glb").error().code, ErrorCode::kNotFound);
  EXPECT_EQ(s->local_file("2_0_0.v1.glb").error().code, ErrorCode::kNotFound);
}

TYPED_TEST(TileStorageContract, AnUncommittedFileIsReplacedAndACommittedOneNever) {
  auto s = this->open();
  ASSERT_TRUE(s);
  ASSERT_TRUE(s->write_tile("1_0_0.v1.glb", bytes("a cut update's")));
  ASSERT_TRUE(s->write_tile("1_0_0.v1.glb", bytes("tile")));
  EXPECT_EQ(*s->read_tile("1_0_0.v1.glb"), bytes("tile"));
  ASSERT_TRUE(*s->commit(record(*s, 1, {"1_0_0.v1.glb"})));
  EXPECT_TRUE(s->write_tile("1_0_0.v1.glb", bytes("tile")));
  EXPECT_TRUE(s->write_tile("1_0_0.v1.glb", bytes("a stale writer's")));  // changes nothing
  EXPECT_EQ(*s->read_tile("1_0_0.v1.glb"), bytes("tile"));
  EXPECT_EQ(*this->open("fresh")->read_tile("1_0_0.v1.glb"), bytes("tile"));
}

// A record whose file holds other bytes than it says (another writer's build under the same name) is refused.
TYPED_TEST(TileStorageContract, ARecordWhoseFileHoldsOtherBytesIsRefused) {
  auto s = this->open();
  ASSERT_TRUE(s);
  ASSERT_TRUE(s->write_tile("1_0_0.v1.glb", bytes("another writer's")));
  TileCommit c = record(*s, 1, {"1_0_0.v1.glb"});
  c.named["1_0_0.v1.glb"] = 4;  // what this writer built: "tile"
  EXPECT_FALSE(*s->commit(c));
  EXPECT_FALSE(*s->read_record());
}

TYPED_TEST(TileStorageContract, AnOlderRecordNeverOverwritesANewerOne) {
  auto a = this->open("a");
  auto b = this->open("b");
  ASSERT_TRUE(a && b);
  ASSERT_TRUE(a->write_tile("1_0_0.v2.glb", bytes("a's")));
  ASSERT_TRUE(*a->commit(record(*a, 2, {"1_0_0.v2.glb"})));
  // b, a second writer of the same mission, still at version 0: its version 1 and its own version 2 are refused.
  ASSERT_TRUE(b->write_tile("1_0_1.v1.glb", bytes("b's")));
  EXPECT_FALSE(*b->commit(record(*b, 1, {"1_0_1.v1.glb"})));
  EXPECT_FALSE(*b->commit(record(*b, 2, {"1_0_1.v1.glb"})));
  EXPECT_EQ((*b->read_record())->version, 2u);
  EXPECT_EQ(*b->committed_version(), 2u);
  EXPECT_EQ(*a->read_tile("1_0_0.v2.glb"), bytes("a's"));
  // A newer one goes in.
  EXPECT_TRUE(*b->commit(record(*b, 3, {"1_0_0.v2.glb", "1_0_1.v1.glb"})));
  EXPECT_EQ((*a->read_record())->version, 3u);
}

TYPED_TEST(TileStorageContract, ARecordNamingAFileNotStoredIsRefused) {
  auto s = this->open();
  ASSERT_TRUE(s);
  ASSERT_TRUE(s->write_tile("1_0_0.v1.glb", bytes("tile")));
  EXPECT_FALSE(*s->commit(record(*s, 1, {"1_0_0.v1.glb", "1_0_1.v1.glb"})));
  EXPECT_FALSE(*s->read_record());
}

TYPED_TEST(TileStorageContract, RetiredAndUnnamedFilesAreCollectedAndKeptOnesStay) {
  auto s = this->open();
  ASSERT_TRUE(s);
  ASSERT_TRUE(s->write_tile("1_0_0.v1.glb", bytes("v1")));
  ASSERT_TRUE(*s->commit(record(*s, 1, {"1_0_0.v1.glb"})));
  ASSERT_TRUE(s->write_tile("1_0_0.v2.glb", bytes("v2")));
  ASSERT_TRUE(*s->commit(record(*s, 2, {"1_0_0.v2.glb"}, {"1_0_0.v1.glb"})));
  EXPECT_TRUE(stored(*s, "1_0_0.v1.glb")) << "the previous version's file stays";
  ASSERT_TRUE(s->write_tile("1_0_0.v3.glb", bytes("v3")));
  // The garbage names a kept file too (the one the new record retains): that one stays.
  ASSERT_TRUE(*s->commit(record(*s, 3, {"1_0_0.v3.glb"}, {"1_0_0.v2.glb"}, {"1_0_0.v1.glb", "1_0_0.v2.glb"})));
  EXPECT_FALSE(stored(*s, "1_0_0.v1.glb"));
  EXPECT_TRUE(stored(*s, "1_0_0.v2.glb"));
  EXPECT_TRUE(stored(*s, "1_0_0.v3.glb"));
  // A cut update's file (version <= the committed one) goes at the next collection.
  ASSERT_TRUE(s->write_tile("1_0_1.v3.glb", bytes("cut")));
  ASSERT_TRUE(s->collect({"1_0_0.v3.glb"}, 3));
  EXPECT_FALSE(stored(*s, "1_0_1.v3.glb"));
  EXPECT_TRUE(stored(*s, "1_0_0.v3.glb"));
  EXPECT_EQ((*s->read_record())->version, 3u);
}

TYPED_TEST(TileStorageContract, RemoveDeletesTheRecordAndEveryFile) {
  auto s = this->open();
  ASSERT_TRUE(s);
  ASSERT_TRUE(s->write_tile("1_0_0.v1.glb", bytes("tile")));
  ASSERT_TRUE(s->write_tile("1_0_1.v1.glb", bytes("unnamed")));
  ASSERT_TRUE(*s->commit(record(*s, 1, {"1_0_0.v1.glb"})));
  ASSERT_TRUE(this->backend.remove_mission());  // what removes a mission's tiles in a shared storage
  ASSERT_TRUE(s->remove());
  EXPECT_FALSE(*s->read_record());
  EXPECT_EQ(*s->committed_version(), 0u);
  EXPECT_FALSE(stored(*s, "1_0_0.v1.glb"));
  EXPECT_FALSE(stored(*s, "1_0_1.v1.glb"));
  auto again = this->open("c");
  ASSERT_TRUE(again);
  EXPECT_FALSE(*again->read_record());
}

TYPED_TEST(TileStorageContract, AStorageOpenedAgainSeesTheLastCommittedRecordAndItsFiles) {
  {
    auto s = this->open("a");
    ASSERT_TRUE(s);
    ASSERT_TRUE(s->write_tile("1_0_0.v1.glb", bytes("v1")));
    ASSERT_TRUE(*s->commit(record(*s, 1, {"1_0_0.v1.glb"})));
    ASSERT_TRUE(s->write_tile("1_0_0.v2.glb", bytes("v2")));
    ASSERT_TRUE(*s->commit(record(*s, 2, {"1_0_0.v2.glb"}, {"1_0_0.v1.glb"})));
    ASSERT_TRUE(s->write_tile("1_0_0.v3.glb", bytes("uncommitted")));
  }
  // With the directory store the same folder; with PostgreSQL another replica's empty cache.
  auto s = this->open("b");
  ASSERT_TRUE(s);
  auto r = s->read_record();
  ASSERT_TRUE(r && *r);
  EXPECT_EQ((*r)->version, 2u);
  EXPECT_EQ((*r)->bytes, bytes("{\"version\":2}"));
  EXPECT_EQ(*s->read_tile("1_0_0.v2.glb"), bytes("v2"));
  auto path = s->local_file("1_0_0.v1.glb");
  ASSERT_TRUE(path) << path.error().message;
  EXPECT_EQ(*read_file_bytes(*path, 1 << 20), bytes("v1"));
}

// A replica's update under way writes files above the committed version: another replica's collection leaves them
// (the directory store is one process's, so it collects them).
TYPED_TEST(TileStorageContract, ACollectionLeavesFilesAboveTheCommittedVersionOnlyWhenShared) {
  auto a = this->open("a");
  auto b = this->open("b");
  ASSERT_TRUE(a && b);
  ASSERT_TRUE(a->write_tile("1_0_0.v1.glb", bytes("v1")));
  ASSERT_TRUE(*a->commit(record(*a, 1, {"1_0_0.v1.glb"})));
  ASSERT_TRUE(a->write_tile("1_0_0.v2.glb", bytes("under way")));
  auto collected = b->collect({"1_0_0.v1.glb"}, 1);
  ASSERT_TRUE(collected) << collected.error().message;
  EXPECT_EQ(stored(*b, "1_0_0.v2.glb"), TypeParam::kShared);
  EXPECT_TRUE(stored(*b, "1_0_0.v1.glb"));
}

class PgTileRows : public TileStorageContract<PostgresBackend> {};

TEST_F(PgTileRows, AMissionsRemovalTakesItsTilesAlong) {
  auto s = open();
  ASSERT_TRUE(s);
  ASSERT_TRUE(s->write_tile("1_0_0.v1.glb", bytes("tile")));
  ASSERT_TRUE(*s->commit(record(*s, 1, {"1_0_0.v1.glb"})));
  ASSERT_TRUE(backend.sql("DELETE FROM missions WHERE name = 'm1'"));
  auto fresh = open("fresh");  // an empty cache: what the rows hold
  ASSERT_TRUE(fresh);
  EXPECT_FALSE(*fresh->read_record());
  EXPECT_FALSE(stored(*fresh, "1_0_0.v1.glb"));
  // A mission that is gone takes no new tile.
  EXPECT_FALSE(fresh->write_tile("1_0_0.v2.glb", bytes("late")));
}

// Another replica's dropped build may bear the name of a tile this one committed (builds are functions of their
// inputs): its deletion leaves what the committed record keeps.
TEST_F(PgTileRows, ADeletionNeverTakesAFileTheCommittedRecordKeeps) {
  auto a = open("a");
  auto b = open("b");
  ASSERT_TRUE(a && b);
  ASSERT_TRUE(a->write_tile("1_0_0.v1.glb", bytes("tile")));
  ASSERT_TRUE(a->write_tile("1_0_1.v1.glb", bytes("dropped")));
  ASSERT_TRUE(*a->commit(record(*a, 1, {"1_0_0.v1.glb"})));
  ASSERT_TRUE(b->delete_tiles({"1_0_0.v1.glb", "1_0_1.v1.glb"}));
  EXPECT_TRUE(stored(*b, "1_0_0.v1.glb"));
  EXPECT_FALSE(stored(*b, "1_0_1.v1.glb"));
}

// A replica that learns of a removal after the mission was made again under the same name leaves its new tiles.
TEST_F(PgTileRows, ALateRemovalLeavesTheTilesOfAMissionMadeAgain) {
  auto s = open();
  ASSERT_TRUE(s);
  ASSERT_TRUE(s->write_tile("1_0_0.v1.glb", bytes("new mission's")));
  ASSERT_TRUE(*s->commit(record(*s, 1, {"1_0_0.v1.glb"})));
  ASSERT_TRUE(open("late")->remove());
  EXPECT_EQ((*s->read_record())->version, 1u);
  EXPECT_TRUE(stored(*open("fresh"), "1_0_0.v1.glb"));
}

TEST(TileFileVersion, IsTheNumberAfterDotV) {
  EXPECT_EQ(tiles::tile_file_version("3_0_1.v12.glb"), 12u);
  EXPECT_EQ(tiles::tile_file_version("0_-3_12_57.v1.glb"), 1u);
  EXPECT_FALSE(tiles::tile_file_version("hierarchy.json"));
  EXPECT_FALSE(tiles::tile_file_version("3_0_1.v.glb"));
  EXPECT_FALSE(tiles::tile_file_version("3_0_1.v1x.glb"));
}

}  // namespace
