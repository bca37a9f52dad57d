// The store contract (service/scene_store.h, service/mission_store.h), run by the same cases on every
// implementation: the directory store (the embedded default) and PostgreSQL (pgstore/), the latter on a throwaway
// server this program starts (tests/common/postgres_server.h), one fresh database per test. Then what only a shared
// database can do: two replicas' stores on one database see each other's keyframes, and a database restart loses and
// duplicates nothing.
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "pgstore/pg_mission_store.h"
#include "pgstore/pg_scene_store.h"
#include "service/mission_store.h"
#include "service/scene_store.h"
#include "tests/common/postgres_server.h"
#include "tests/common/test_data.h"
#include "tests/common/typed_test_names.h"

using namespace rgbdcast;
using namespace rgbdcast::service;

namespace {

struct DirectoryBackend {
  static constexpr const char* kName = "Directory";
  Status prepare() {
    dir = test::temp_dir("store-contract");
    return ok_status();
  }
  Result<std::unique_ptr<SceneStore>> scenes() { return SceneStore::open(dir); }
  Result<std::unique_ptr<MissionStore>> missions() { return MissionStore::open(dir); }
  std::string dir;
};

struct PostgresBackend {
  static constexpr const char* kName = "Postgres";
  Status prepare() {
    auto db = test::fresh_database();
    if (!db) return db.error();
    uri = *db;
    return ok_status();
  }
  Result<std::unique_ptr<SceneStore>> scenes() {
    auto s = pgstore::PgSceneStore::open(uri, 4);
    if (!s) return s.error();
    return std::unique_ptr<SceneStore>(std::move(*s));
  }
  Result<std::unique_ptr<MissionStore>> missions() {
    auto s = pgstore::PgMissionStore::open(uri, 4, 0.2);
    if (!s) return s.error();
    return std::unique_ptr<MissionStore>(std::move(*s));
  }
  std::string uri;
};

template <class Backend>
class StoreContract : public ::testing::Test {
 protected:
  void SetUp() override {
    auto st = backend.prepare();
    if (!st) RGBDCAST_MISSING_PREREQUISITE("store backend: " + st.error().message);
  }
  std::unique_ptr<SceneStore> scenes() {
    auto s = backend.scenes();
    EXPECT_TRUE(s) << s.error().message;
    return s ? std::move(*s) : nullptr;
  }
  std::unique_ptr<MissionStore> missions() {
    auto s = backend.missions();
    EXPECT_TRUE(s) << s.error().message;
    return s ? std::move(*s) : nullptr;
  }
  Backend backend;
};

using Backends = ::testing::Types<DirectoryBackend, PostgresBackend>;
TYPED_TEST_SUITE(StoreContract, Backends, test::SelfNamedTypes);

std::vector<std::uint8_t> bytes(const std::string& s) { return {s.begin(), s.end()}; }

MissionKeyframe keyframe(const std::string& mission, std::int64_t seq, std::int64_t rev = 0) {
  MissionKeyframe k;
  k.mission = mission;
  k.seq = seq;
  k.rev = rev;
  k.pose = {0.1 * static_cast<double>(seq), 0, 0, 0, 0, 0, 1};
  k.triangles = 10 + static_cast<std::uint64_t>(seq);
  k.captured = 100.0 + static_cast<double>(seq);
  k.received = 200.0 + static_cast<double>(seq);
  k.camera = {{"fx", 525.0}};
  return k;
}

std::vector<std::int64_t> seqs(const std::vector<MissionKeyframe>& ks) {
  std::vector<std::int64_t> out;
  for (const auto& k : ks) out.push_back(k.seq);
  return out;
}

}  // namespace

TYPED_TEST(StoreContract, ScenesPutGetListRemoveAndSurviveAReopen) {
  std::string id_a, id_b;
  {
    auto store = this->scenes();
    ASSERT_TRUE(store);
    auto a = store->put(bytes("glTF-A"), {{"triangles", 10}, {"source", "a.glb"}});
    ASSERT_TRUE(a) << a.error().message;
    auto b = store->put(bytes("glTF-BB"), nlohmann::json::array());  // not an object: stored as {}
    ASSERT_TRUE(b) << b.error().message;
    id_a = a->id;
    id_b = b->id;
    EXPECT_TRUE(is_valid_scene_id(id_a));
    EXPECT_NE(id_a, id_b);
    EXPECT_EQ(a->etag, etag_of(bytes("glTF-A").data(), 6));
    EXPECT_EQ(a->metadata()["id"], id_a);
    EXPECT_EQ(a->metadata()["bytes"], 6);
    EXPECT_EQ(store->count(), 2u);
    EXPECT_EQ(store->total_bytes(), 13u);
    auto listed = store->list();
    ASSERT_EQ(listed.size(), 2u);
    EXPECT_EQ(listed[0].id, id_a);  // oldest first
    EXPECT_EQ(listed[1].id, id_b);
    size_t seen = 0;
    store->for_each([&](const StoredScene& s) { seen += s.bytes; });
    EXPECT_EQ(seen, 13u);
    EXPECT_FALSE(store->get("../" + id_a));
    EXPECT_FALSE(store->get(new_scene_id()));
    EXPECT_EQ(store->read_glb(new_scene_id()).error().code, ErrorCode::kNotFound);
    EXPECT_EQ(store->read_glb("'; DROP TABLE scenes; --").error().code, ErrorCode::kNotFound);
    EXPECT_EQ(store->remove(new_scene_id()).error().code, ErrorCode::kNotFound);
  }
  auto store = this->scenes();  // a restart
  ASSERT_TRUE(store);
  auto a = store->get(id_a);
  ASSERT_TRUE(a);
  EXPECT_EQ(a->bytes, 6u);
  EXPECT_EQ(a->triangles, 10u);
  EXPECT_EQ(a->source, "a.glb");
  EXPECT_EQ(*store->read_glb(id_b), bytes("glTF-BB"));
  ASSERT_TRUE(store->remove(id_a));
  EXPECT_FALSE(store->get(id_a));
  EXPECT_EQ(store->read_glb(id_a).error().code, ErrorCode::kNotFound);
  EXPECT_EQ(store->count(), 1u);
  EXPECT_TRUE(store->ping());
}

TYPED_TEST(StoreContract, KeyframePutOutcomesAreIdempotentAndConflictsAreSeen) {
  auto store = this->missions();
  ASSERT_TRUE(store);
  auto& s = *store;
  auto a = s.put(keyframe("m", 0), bytes("glb-0"));
  ASSERT_TRUE(a) << a.error().message;
  EXPECT_EQ(a->outcome, PutOutcome::kCreated);
  EXPECT_EQ(a->keyframe.bytes, 5u);
  EXPECT_EQ(s.put(keyframe("m", 0), bytes("glb-0"))->outcome, PutOutcome::kSame);
  EXPECT_EQ(s.put(keyframe("m", 0), bytes("glb-X"))->outcome, PutOutcome::kConflict);
  auto moved = keyframe("m", 0);
  moved.pose[0] = 5;
  auto conflict = s.put(moved, bytes("glb-0"));
  EXPECT_EQ(conflict->outcome, PutOutcome::kConflict);
  EXPECT_EQ(conflict->keyframe.pose[0], 0.0);  // what is stored, not what was sent
  for (const char* bad : {"", "a.b", "../x", "a/b", "x'y", "\xc3\xa9"})
    EXPECT_EQ(s.put(keyframe(bad, 0), bytes("x")).error().code, ErrorCode::kInvalidArgument) << bad;
  EXPECT_FALSE(s.put(keyframe(std::string(65, 'a'), 0), bytes("x")));
  EXPECT_TRUE(s.put(keyframe(std::string(64, 'a'), 0), bytes("x")));
  EXPECT_FALSE(s.put(keyframe("m", -1), bytes("x")));
  EXPECT_FALSE(s.put(keyframe("m", kMaxKeyframeSeq + 1), bytes("x")));
  EXPECT_FALSE(s.put(keyframe("m", 1, -1), bytes("x")));
  EXPECT_EQ(s.keyframes("m")->size(), 1u);
  EXPECT_EQ(s.count(), 2u);
  EXPECT_EQ(*s.read_glb("m", 0, 0), bytes("glb-0"));
  EXPECT_EQ(s.read_glb("m", 0, 1).error().code, ErrorCode::kNotFound);
  EXPECT_EQ(s.read_glb("nope", 0, 0).error().code, ErrorCode::kNotFound);
}

// The same keyframe posted by 8 senders at once (a robot's retries through several replicas): stored once, every
// other answer kSame; 8 different bodies for one key: one stored, 7 conflicts.
TYPED_TEST(StoreContract, ConcurrentPostsOfOneKeyStoreItOnce) {
  auto store = this->missions();
  ASSERT_TRUE(store);
  std::atomic<int> created{0}, same{0}, conflict{0}, failed{0};
  auto post_all = [&](bool distinct_bodies, std::int64_t seq) {
    std::vector<std::thread> senders;
    for (int i = 0; i < 8; ++i)
      senders.emplace_back([&, i] {
        auto r = store->put(keyframe("c", seq), bytes(distinct_bodies ? "body-" + std::to_string(i) : "body"));
        if (!r)
          ++failed;
        else if (r->outcome == PutOutcome::kCreated)
          ++created;
        else if (r->outcome == PutOutcome::kSame)
          ++same;
        else if (r->outcome == PutOutcome::kConflict)
          ++conflict;
      });
    for (auto& t : senders) t.join();
  };
  post_all(false, 0);
  EXPECT_EQ(created.load(), 1);
  EXPECT_EQ(same.load(), 7);
  created = 0;
  post_all(true, 1);
  EXPECT_EQ(created.load(), 1);
  EXPECT_EQ(conflict.load(), 7);
  EXPECT_EQ(failed.load(), 0);
  EXPECT_EQ(seqs(*store->keyframes("c")), (std::vector<std::int64_t>{0, 1}));
}

TYPED_TEST(StoreContract, RevisionsReplaceAndALowerOneIsStale) {
  {
    auto store = this->missions();
    ASSERT_TRUE(store);
    ASSERT_TRUE(store->put(keyframe("m", 3), bytes("rev0")));
    ASSERT_TRUE(store->mark_available("m", 3, 1000.0));
    auto r2 = store->put(keyframe("m", 3, 2), bytes("rev2"));
    ASSERT_TRUE(r2) << r2.error().message;
    EXPECT_EQ(r2->outcome, PutOutcome::kReplaced);
    EXPECT_EQ(r2->keyframe.first_available, 1000.0);  // the seq was viewable since its first revision
    auto stale = store->put(keyframe("m", 3, 1), bytes("rev1"));
    EXPECT_EQ(stale->outcome, PutOutcome::kStale);
    EXPECT_EQ(stale->keyframe.rev, 2);
    EXPECT_EQ(store->put(keyframe("m", 3, 0), bytes("rev0"))->outcome, PutOutcome::kStale);
    EXPECT_EQ(store->put(keyframe("m", 3, 2), bytes("rev2"))->outcome, PutOutcome::kSame);
    EXPECT_EQ(store->read_glb("m", 3, 0).error().code, ErrorCode::kNotFound);  // one surface per seq
    EXPECT_EQ(*store->read_glb("m", 3, 2), bytes("rev2"));
    ASSERT_TRUE(store->mark_available("m", 3, 1001.0));
    auto arrivals = *store->arrivals("m");
    ASSERT_EQ(arrivals.size(), 2u);  // each revision is an event of its own
    EXPECT_EQ(arrivals[1].event_id(), "3-2");
  }
  auto store = this->missions();
  ASSERT_TRUE(store);
  auto ks = *store->keyframes("m");
  ASSERT_EQ(ks.size(), 1u);
  EXPECT_EQ(ks[0].rev, 2);
  EXPECT_EQ(ks[0].available, 1001.0);
  EXPECT_EQ(ks[0].first_available, 1000.0);
  EXPECT_EQ(store->arrivals("m")->size(), 1u);  // after a restart: one event per keyframe
}

TYPED_TEST(StoreContract, EventsInArrivalOrderWithCursorsAndRemoval) {
  {
    auto store = this->missions();
    ASSERT_TRUE(store);
    auto& s = *store;
    for (std::int64_t seq : {0, 1, 2, 5, 3, 4}) {  // 5 before 3 and 4: arrival order, not seq order
      ASSERT_TRUE(s.put(keyframe("m", seq), bytes("glb-" + std::to_string(seq))));
      ASSERT_TRUE(s.mark_available("m", seq, 1000.0 + static_cast<double>(s.arrivals("m")->size())));
    }
    ASSERT_TRUE(s.put(keyframe("m", 6), bytes("stored, not yet viewable")));
    EXPECT_EQ(seqs(*s.keyframes("m")), (std::vector<std::int64_t>{0, 1, 2, 3, 4, 5, 6}));
    EXPECT_EQ(seqs(*s.arrivals("m")), (std::vector<std::int64_t>{0, 1, 2, 5, 3, 4}));
    auto after5 = s.cursor_after("m", MissionEventId{5, 0});
    ASSERT_TRUE(after5);
    auto batch = s.wait_events("m", *after5, std::chrono::milliseconds(0));
    EXPECT_TRUE(batch.exists);
    EXPECT_EQ(seqs(batch.events), (std::vector<std::int64_t>{3, 4}));
    EXPECT_FALSE(s.cursor_after("nope", std::nullopt));
    // A waiting stream is woken by the keyframe becoming available.
    std::thread marker([&] { (void)s.mark_available("m", 6, 2000.0); });
    auto live = s.wait_events("m", *after5, std::chrono::milliseconds(10000));
    marker.join();
    EXPECT_EQ(seqs(live.events), (std::vector<std::int64_t>{6}));
    EXPECT_EQ(s.mark_available("m", 99, 1.0).error().code, ErrorCode::kNotFound);
  }
  auto store = this->missions();  // a restart rebuilds the arrival order from the stored times
  ASSERT_TRUE(store);
  auto& s = *store;
  EXPECT_EQ(seqs(*s.arrivals("m")), (std::vector<std::int64_t>{0, 1, 2, 5, 3, 4, 6}));
  auto old = *s.cursor_after("m", std::nullopt);
  ASSERT_TRUE(s.remove("m"));
  EXPECT_FALSE(s.wait_events("m", old, std::chrono::milliseconds(10)).exists);
  EXPECT_FALSE(s.keyframes("m"));
  EXPECT_EQ(s.read_glb("m", 0, 0).error().code, ErrorCode::kNotFound);
  EXPECT_EQ(s.remove("m").error().code, ErrorCode::kNotFound);
  ASSERT_TRUE(s.put(keyframe("m", 0), bytes("new")));  // a mission made again is a new stream
  EXPECT_FALSE(s.wait_events("m", old, std::chrono::milliseconds(10)).exists);
  EXPECT_EQ(s.keyframes("m")->size(), 1u);
}

// Two replicas on one database: a keyframe stored and made available through one is an event on the other (its
// listener applies the change), once; a put through the other of the same key is kSame.
TEST(PostgresStores, AKeyframeStoredThroughOneReplicaIsAnEventOnTheOther) {
  PostgresBackend backend;
  if (auto st = backend.prepare(); !st) RGBDCAST_MISSING_PREREQUISITE("postgres: " + st.error().message);
  auto a = pgstore::PgMissionStore::open(backend.uri, 2, 0.2);
  auto b = pgstore::PgMissionStore::open(backend.uri, 2, 0.2);
  ASSERT_TRUE(a && b);
  ASSERT_TRUE((*a)->put(keyframe("shared", 0), bytes("k0")));
  ASSERT_TRUE((*a)->mark_available("shared", 0, 1000.0));
  // b may not know the mission yet: wait for it through its listener (bounded), then for the event.
  std::optional<EventCursor> cursor;
  for (int i = 0; i < 200 && !cursor; ++i) {
    cursor = (*b)->cursor_after("shared", std::nullopt);
    if (!cursor) std::this_thread::sleep_for(std::chrono::milliseconds(25));
  }
  ASSERT_TRUE(cursor) << "replica b never learnt of the mission";
  auto first = (*b)->wait_events("shared", *cursor, std::chrono::milliseconds(5000));
  EXPECT_EQ(seqs(first.events), (std::vector<std::int64_t>{0}));
  std::thread later([&] {
    (void)(*a)->put(keyframe("shared", 1), bytes("k1"));
    (void)(*a)->mark_available("shared", 1, 1001.0);
  });
  std::vector<MissionKeyframe> seen;
  for (int i = 0; i < 50 && seen.empty(); ++i) {
    auto batch = (*b)->wait_events("shared", *cursor, std::chrono::milliseconds(200));
    seen.insert(seen.end(), batch.events.begin(), batch.events.end());
  }
  later.join();
  EXPECT_EQ(seqs(seen), (std::vector<std::int64_t>{1}));
  EXPECT_EQ((*b)->put(keyframe("shared", 1), bytes("k1"))->outcome, PutOutcome::kSame);
  EXPECT_EQ((*b)->put(keyframe("shared", 1), bytes("other"))->outcome, PutOutcome::kConflict);
  EXPECT_EQ(*(*b)->read_glb("shared", 1, 0), bytes("k1"));
  ASSERT_TRUE((*b)->remove("shared"));
  for (int i = 0; i < 200 && (*a)->keyframes("shared"); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(25));
  EXPECT_FALSE((*a)->keyframes("shared"));
  EXPECT_EQ((*a)->applied_change(), (*b)->applied_change());
}

// The database killed (-9) and started again under a replica: its writes fail while the database is down, then its
// connections are made again; every keyframe acknowledged before is there once, and a retried post is kSame.
TEST(PostgresStores, ADatabaseRestartLosesAndDuplicatesNothing) {
  PostgresBackend backend;
  if (auto st = backend.prepare(); !st) RGBDCAST_MISSING_PREREQUISITE("postgres: " + st.error().message);
  auto store = pgstore::PgMissionStore::open(backend.uri, 2, 0.2);
  ASSERT_TRUE(store);
  for (std::int64_t seq = 0; seq < 5; ++seq) ASSERT_TRUE((*store)->put(keyframe("r", seq), bytes("k")));
  std::string why;
  const auto restarted = test::shared_postgres(&why)->restart();
  ASSERT_TRUE(restarted) << restarted.error().message;
  // The pooled connections died with the server: at most one failed attempt each, then new ones.
  int acknowledged = 5, failures = 0;
  for (std::int64_t seq = 5; seq < 10; ++seq) {
    for (int attempt = 0; attempt < 5; ++attempt) {
      auto r = (*store)->put(keyframe("r", seq), bytes("k"));
      if (r) {
        ++acknowledged;
        break;
      }
      EXPECT_EQ(r.error().code, ErrorCode::kUnavailable) << r.error().message;
      ++failures;
    }
  }
  EXPECT_EQ(acknowledged, 10);
  EXPECT_LE(failures, 4);
  EXPECT_EQ((*store)->put(keyframe("r", 4), bytes("k"))->outcome, PutOutcome::kSame);
  auto fresh = pgstore::PgMissionStore::open(backend.uri, 2, 0.2);  // a replica started after the restart
  ASSERT_TRUE(fresh);
  EXPECT_EQ(seqs(*(*fresh)->keyframes("r")), (std::vector<std::int64_t>{0, 1, 2, 3, 4, 5, 6, 7, 8, 9}));
}
