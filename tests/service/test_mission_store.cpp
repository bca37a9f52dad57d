// The mission store on its own (service/mission_store.h): idempotency outcomes, events in arrival order with
// Last-Event-ID cursors (a sender that sends the newest keyframe first), waiting and waking, deletion by one rename,
// and what open() does with what a crash or a damaged file left.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <thread>

#include "base/stopwatch.h"
#include "service/mission_store.h"
#include "tests/common/test_data.h"

namespace fs = std::filesystem;
using namespace rgbdcast;
using namespace rgbdcast::service;

namespace {

MissionKeyframe keyframe(const std::string& mission, std::int64_t seq) {
  MissionKeyframe k;
  k.mission = mission;
  k.seq = seq;
  k.pose = {0.1 * static_cast<double>(seq), 0, 0, 0, 0, 0, 1};
  k.triangles = 10;
  k.captured = 100.0 + static_cast<double>(seq);
  k.received = 200.0 + static_cast<double>(seq);
  k.camera = {{"fx", 525.0}};
  return k;
}

std::vector<std::uint8_t> bytes(const std::string& s) { return {s.begin(), s.end()}; }

std::vector<std::int64_t> seqs(const std::vector<MissionKeyframe>& ks) {
  std::vector<std::int64_t> out;
  for (const auto& k : ks) out.push_back(k.seq);
  return out;
}

}  // namespace

TEST(MissionStore, PutOutcomesAndNames) {
  const std::string dir = rgbdcast::test::temp_dir("mission-store-put");
  auto store = MissionStore::open(dir);
  ASSERT_TRUE(store) << store.error().message;
  auto& s = **store;
  auto a = s.put(keyframe("m", 0), bytes("glb-0"));
  ASSERT_TRUE(a);
  EXPECT_EQ(a->outcome, PutOutcome::kCreated);
  EXPECT_EQ(a->keyframe.bytes, 5u);
  auto same = s.put(keyframe("m", 0), bytes("glb-0"));
  ASSERT_TRUE(same);
  EXPECT_EQ(same->outcome, PutOutcome::kSame);
  auto other_body = s.put(keyframe("m", 0), bytes("glb-X"));
  EXPECT_EQ(other_body->outcome, PutOutcome::kConflict);
  auto moved = keyframe("m", 0);
  moved.pose[0] = 5;
  EXPECT_EQ(s.put(moved, bytes("glb-0"))->outcome, PutOutcome::kConflict);
  for (const char* bad : {"", "a.b", "../x", "a/b", "\xc3\xa9"})
    EXPECT_FALSE(s.put(keyframe(bad, 0), bytes("x"))) << bad;
  EXPECT_FALSE(s.put(keyframe(std::string(65, 'a'), 0), bytes("x")));
  EXPECT_TRUE(s.put(keyframe(std::string(64, 'a'), 0), bytes("x")));
  EXPECT_FALSE(s.put(keyframe("m", -1), bytes("x")));
  EXPECT_FALSE(s.put(keyframe("m", kMaxKeyframeSeq + 1), bytes("x")));
  EXPECT_EQ(s.keyframes("m")->size(), 1u);
  EXPECT_EQ(s.count(), 2u);
  rgbdcast::test::remove_tree_quietly(dir);
}

TEST(MissionStore, EventsInArrivalOrderWithCursorsAndWakeups) {
  const std::string dir = rgbdcast::test::temp_dir("mission-store-events");
  auto store = MissionStore::open(dir);
  ASSERT_TRUE(store);
  auto& s = **store;
  // The sender sends 5 before 3 and 4 (newest first when the link is short).
  for (std::int64_t seq : {0, 1, 2, 5, 3, 4}) {
    ASSERT_TRUE(s.put(keyframe("m", seq), bytes("glb-" + std::to_string(seq))));
    ASSERT_TRUE(s.mark_available("m", seq, 1000.0 + static_cast<double>(s.arrivals("m")->size())));
  }
  EXPECT_EQ(seqs(*s.keyframes("m")), (std::vector<std::int64_t>{0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(seqs(*s.arrivals("m")), (std::vector<std::int64_t>{0, 1, 2, 5, 3, 4}));
  auto after5 = s.cursor_after("m", MissionEventId{5});
  ASSERT_TRUE(after5);
  auto batch = s.wait_events("m", *after5, std::chrono::milliseconds(0));
  EXPECT_TRUE(batch.exists);
  EXPECT_EQ(seqs(batch.events), (std::vector<std::int64_t>{3, 4}));  // what came after 5, though lower
  auto fresh = s.cursor_after("m", std::nullopt);
  EXPECT_EQ(s.wait_events("m", *fresh, std::chrono::milliseconds(0)).events.size(), 6u);
  auto unknown_id = s.cursor_after("m", MissionEventId{99});  // not a keyframe: everything
  EXPECT_EQ(s.wait_events("m", *unknown_id, std::chrono::milliseconds(0)).events.size(), 6u);
  EXPECT_FALSE(s.cursor_after("nope", std::nullopt));

  // A waiting stream wakes when a keyframe becomes available, not when it is only stored.
  auto cursor = *s.cursor_after("m", MissionEventId{4});
  const auto t0 = std::chrono::steady_clock::now();  // before the writer starts: its sleeps bound the wait below
  std::thread writer([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    (void)s.put(keyframe("m", 6), bytes("glb-6"));
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    (void)s.mark_available("m", 6, 2000.0);
  });
  auto live = s.wait_events("m", cursor, std::chrono::milliseconds(5000));
  const double waited_ms = ms_since(t0);
  writer.join();
  EXPECT_EQ(seqs(live.events), (std::vector<std::int64_t>{6}));  // woken by it: a timeout returns none
  EXPECT_GE(waited_ms, 150.0);  // not by the put 100 ms in: by mark_available, 100 ms later
  EXPECT_TRUE(s.wait_events("m", cursor, std::chrono::milliseconds(50)).events.empty());  // timeout: nothing new

  // Deleting ends the stream (exists = false), even if a mission of the same name is made again.
  auto old = *s.cursor_after("m", std::nullopt);
  ASSERT_TRUE(s.remove("m"));
  EXPECT_FALSE(s.wait_events("m", old, std::chrono::milliseconds(10)).exists);
  ASSERT_TRUE(s.put(keyframe("m", 0), bytes("new")));
  EXPECT_FALSE(s.wait_events("m", old, std::chrono::milliseconds(10)).exists);
  EXPECT_FALSE(fs::exists(dir + "/missions/m/5.glb"));
  rgbdcast::test::remove_tree_quietly(dir);
}

TEST(MissionStore, OpenRestoresOrderAndCleansWhatACrashLeft) {
  const std::string dir = rgbdcast::test::temp_dir("mission-store-open");
  {
    auto store = MissionStore::open(dir);
    ASSERT_TRUE(store);
    for (std::int64_t seq : {2, 0, 1}) {
      ASSERT_TRUE((*store)->put(keyframe("m", seq), bytes("g" + std::to_string(seq))));
      ASSERT_TRUE((*store)->mark_available("m", seq, 500.0 + static_cast<double>(seq == 2 ? 0 : seq + 1)));
    }
    ASSERT_TRUE((*store)->put(keyframe("m", 7), bytes("never available")));  // crash before mark_available
  }
  const std::string m = dir + "/missions/m";
  std::ofstream(m + "/.tmp-8.glb-1234") << "partial";
  std::ofstream(m + "/9.glb") << "a GLB whose JSON was never written";
  std::ofstream(m + "/3.json") << R"({"mission":"m","seq":3,"bytes":"many"})";  // wrong type
  std::ofstream(m + "/3.glb") << "g3";
  fs::create_directories(dir + "/missions/.deleting-old-123/sub");
  std::ofstream(m + "/notes.txt") << "not ours: left alone";
  auto store = MissionStore::open(dir);
  ASSERT_TRUE(store) << store.error().message;
  auto& s = **store;
  EXPECT_EQ(seqs(*s.keyframes("m")), (std::vector<std::int64_t>{0, 1, 2, 7}));
  EXPECT_EQ(seqs(*s.arrivals("m")), (std::vector<std::int64_t>{2, 0, 1, 7}));
  EXPECT_GT(s.keyframes("m")->back().available, 1e9);  // available from the restart on
  ASSERT_EQ(s.quarantined().size(), 1u);
  EXPECT_NE(s.quarantined()[0].find("keyframe 3"), std::string::npos) << s.quarantined()[0];
  EXPECT_TRUE(fs::exists(dir + "/quarantine/mission-m-3.json"));
  EXPECT_TRUE(fs::exists(dir + "/quarantine/mission-m-3.glb"));
  EXPECT_FALSE(fs::exists(m + "/.tmp-8.glb-1234"));
  EXPECT_FALSE(fs::exists(m + "/9.glb"));
  EXPECT_FALSE(fs::exists(dir + "/missions/.deleting-old-123"));
  EXPECT_TRUE(fs::exists(m + "/notes.txt"));
  rgbdcast::test::remove_tree_quietly(dir);
}

// Revisions (a refinement of a keyframe sent when the link is idle): (seq, rev) is the idempotency key, a higher rev
// replaces the keyframe (one surface per seq, one GLB on disk), a lower one is stale, and a restart keeps the newest.
TEST(MissionStore, AHigherRevisionReplacesTheKeyframeAndALowerOneIsStale) {
  const std::string dir = rgbdcast::test::temp_dir("mission-store-rev");
  const std::string m = dir + "/missions/m";
  {
    auto store = MissionStore::open(dir);
    ASSERT_TRUE(store);
    auto& s = **store;
    ASSERT_EQ(s.put(keyframe("m", 0), bytes("coarse-0"))->outcome, PutOutcome::kCreated);
    ASSERT_TRUE(s.mark_available("m", 0, 1000.0));
    ASSERT_EQ(s.put(keyframe("m", 1), bytes("coarse-1"))->outcome, PutOutcome::kCreated);
    ASSERT_TRUE(s.mark_available("m", 1, 1001.0));

    auto fine = keyframe("m", 0);
    fine.rev = 1;
    fine.triangles = 99;
    auto replaced = s.put(fine, bytes("a finer keyframe 0"));
    ASSERT_TRUE(replaced);
    EXPECT_EQ(replaced->outcome, PutOutcome::kReplaced);
    EXPECT_EQ(replaced->keyframe.rev, 1);
    EXPECT_DOUBLE_EQ(replaced->keyframe.first_available, 1000.0);  // viewable since its first revision
    EXPECT_FALSE(fs::exists(m + "/0.glb"));                        // the replaced revision's GLB is gone
    EXPECT_TRUE(fs::exists(m + "/0.r1.glb"));
    ASSERT_TRUE(s.mark_available("m", 0, 1002.0));

    // The same (seq, rev) and body again: kSame; another body under it: kConflict; the older rev: kStale.
    EXPECT_EQ(s.put(fine, bytes("a finer keyframe 0"))->outcome, PutOutcome::kSame);
    EXPECT_EQ(s.put(fine, bytes("yet another body"))->outcome, PutOutcome::kConflict);
    auto stale = s.put(keyframe("m", 0), bytes("coarse-0"));
    ASSERT_TRUE(stale);
    EXPECT_EQ(stale->outcome, PutOutcome::kStale);
    EXPECT_EQ(stale->keyframe.rev, 1);

    const auto ks = *s.keyframes("m");
    ASSERT_EQ(ks.size(), 2u);  // one keyframe per seq
    EXPECT_EQ(ks[0].rev, 1);
    EXPECT_EQ(ks[0].bytes, 18u);
    EXPECT_EQ(ks[0].triangles, 99u);
    EXPECT_DOUBLE_EQ(ks[0].available, 1002.0);
    EXPECT_DOUBLE_EQ(ks[0].first_available, 1000.0);
    auto glb = s.read_glb("m", 0, 1);
    ASSERT_TRUE(glb);
    EXPECT_EQ(*glb, bytes("a finer keyframe 0"));
    EXPECT_FALSE(s.read_glb("m", 0, 0));

    // The revision is an event of its own, with its own id; a cursor after it or after the first revision.
    const auto events = *s.arrivals("m");
    ASSERT_EQ(events.size(), 3u);
    EXPECT_EQ(events[0].event_id(), "0");
    EXPECT_EQ(events[1].event_id(), "1");
    EXPECT_EQ(events[2].event_id(), "0-1");
    EXPECT_EQ(events[0].rev, 0);  // what arrived then, not what is stored now
    EXPECT_EQ(s.cursor_after("m", MissionEventId{0, 0})->next, 1u);
    EXPECT_EQ(s.cursor_after("m", MissionEventId{0, 1})->next, 3u);
    EXPECT_EQ(s.cursor_after("m", MissionEventId{0, 7})->next, 0u);  // unknown: from the start
  }
  // A replacement cut short after its JSON (the old GLB still there) and one cut short before it (a newer GLB
  // without its JSON): open() keeps the committed revision and removes the other files.
  std::ofstream(m + "/0.glb") << "coarse-0";
  std::ofstream(m + "/1.r4.glb") << "never committed";
  auto store = MissionStore::open(dir);
  ASSERT_TRUE(store) << store.error().message;
  auto& s = **store;
  const auto ks = *s.keyframes("m");
  ASSERT_EQ(ks.size(), 2u);
  EXPECT_EQ(ks[0].rev, 1);
  EXPECT_EQ(ks[1].rev, 0);
  EXPECT_DOUBLE_EQ(ks[0].first_available, 1000.0);
  EXPECT_FALSE(fs::exists(m + "/0.glb"));
  EXPECT_FALSE(fs::exists(m + "/1.r4.glb"));
  EXPECT_TRUE(fs::exists(m + "/0.r1.glb"));
  EXPECT_TRUE(fs::exists(m + "/1.glb"));
  EXPECT_EQ(*s.read_glb("m", 0, 1), bytes("a finer keyframe 0"));
  EXPECT_EQ(s.put(keyframe("m", 0), bytes("coarse-0"))->outcome, PutOutcome::kStale);  // still stale after it
  EXPECT_EQ(parse_event_id("12-3")->rev, 3);
  EXPECT_EQ(parse_event_id("12")->seq, 12);
  for (const char* bad : {"", "-1", "1-", "a", "1-b", "99999999999"}) EXPECT_FALSE(parse_event_id(bad)) << bad;
  rgbdcast::test::remove_tree_quietly(dir);
}
