// The outbox on disk (stream/outbox.h): entries survive a reopen, seq numbering continues, attempted entries are
// never rewritten, a GLB left without its JSON is removed, deferred keyframes' records survive until their keyframe
// is added, one outbox serves one mission.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "stream/outbox.h"
#include "tests/common/test_data.h"

namespace rgbdcast::stream {
namespace {

namespace fs = std::filesystem;

std::vector<std::uint8_t> bytes(size_t n, std::uint8_t v) { return std::vector<std::uint8_t>(n, v); }

TEST(Outbox, EntriesSurviveAReopenAndSeqContinues) {
  const std::string dir = test::temp_dir("outbox_reopen");
  {
    auto box = Outbox::open(dir, "m1");
    ASSERT_TRUE(box) << box.error().message;
    OutboxEntry e;
    e.frame_index = 12;
    e.pose = {1, 2, 3, 0, 0, 0, 1};
    e.captured = 1700000000.5;
    e.budget_kb = 40;
    auto a = (*box)->add(e, bytes(1000, 1));
    ASSERT_TRUE(a);
    EXPECT_EQ(a->seq, 0);
    e.frame_index = 30;
    auto b = (*box)->add(e, bytes(2000, 2));
    ASSERT_TRUE(b);
    EXPECT_EQ(b->seq, 1);
    ASSERT_TRUE((*box)->mark_acked(0, R"({"seq":0,"available":1.5})"));
    ASSERT_TRUE((*box)->mark_attempted(1));
  }
  auto box = Outbox::open(dir, "m1");
  ASSERT_TRUE(box) << box.error().message;
  const auto entries = (*box)->entries();
  ASSERT_EQ(entries.size(), 2u);
  EXPECT_TRUE(entries[0].acked);
  EXPECT_EQ(entries[0].frame_index, 12);
  EXPECT_DOUBLE_EQ(entries[0].captured, 1700000000.5);
  EXPECT_NE(entries[0].ack_json.find("available"), std::string::npos);
  EXPECT_TRUE(entries[1].attempted);
  EXPECT_TRUE(entries[1].pending());
  EXPECT_EQ(entries[1].bytes, 2000u);
  EXPECT_EQ((*box)->next_seq(), 2);
  auto glb = (*box)->read_glb(1);
  ASSERT_TRUE(glb);
  EXPECT_EQ(*glb, bytes(2000, 2));
  test::remove_tree_quietly(dir);
}

TEST(Outbox, OnlyNeverAttemptedEntriesAreCoarsened) {
  const std::string dir = test::temp_dir("outbox_coarsen");
  auto box = Outbox::open(dir, "m1");
  ASSERT_TRUE(box);
  ASSERT_TRUE((*box)->add(OutboxEntry{}, bytes(4000, 1)));
  ASSERT_TRUE((*box)->add(OutboxEntry{}, bytes(4000, 2)));
  ASSERT_TRUE((*box)->coarsen(0, bytes(1000, 3), 10, 5));
  ASSERT_TRUE((*box)->mark_attempted(1));
  auto refused = (*box)->coarsen(1, bytes(1000, 4), 10, 5);
  EXPECT_FALSE(refused);
  auto e0 = (*box)->entry(0), e1 = (*box)->entry(1);
  EXPECT_TRUE(e0->coarsened);
  EXPECT_EQ(e0->bytes, 1000u);
  EXPECT_DOUBLE_EQ(e0->budget_kb, 10);
  EXPECT_EQ(e1->bytes, 4000u);
  EXPECT_EQ(*(*box)->read_glb(1), bytes(4000, 2));
  test::remove_tree_quietly(dir);
}

// A refinement: an acknowledged entry's next revision, under its own GLB name, queued again; the first revision's
// answer and size are kept; only acknowledged entries are revised; a reopen keeps the revision and removes the GLB
// a revision cut short left.
TEST(Outbox, AnAcknowledgedEntryIsRevisedUnderItsOwnGlbAndSurvivesAReopen) {
  const std::string dir = test::temp_dir("outbox_revise");
  {
    auto box = Outbox::open(dir, "m1");
    ASSERT_TRUE(box);
    ASSERT_TRUE((*box)->add(OutboxEntry{}, bytes(4000, 1)));
    ASSERT_TRUE((*box)->add(OutboxEntry{}, bytes(4000, 2)));
    EXPECT_FALSE((*box)->revise(0, bytes(9000, 3), 90, 50));  // not acknowledged yet
    ASSERT_TRUE((*box)->mark_acked(0, R"({"seq":0,"available":7.5})"));
    ASSERT_TRUE((*box)->revise(0, bytes(9000, 3), 90, 50));
    const auto e = *(*box)->entry(0);
    EXPECT_EQ(e.rev, 1);
    EXPECT_TRUE(e.pending());
    EXPECT_FALSE(e.attempted);
    EXPECT_EQ(e.bytes, 9000u);
    EXPECT_EQ(e.first_bytes, 4000u);
    EXPECT_NE(e.first_ack.find("7.5"), std::string::npos);
    EXPECT_DOUBLE_EQ(e.budget_kb, 90);
    EXPECT_EQ(*(*box)->read_glb(0), bytes(9000, 3));
    EXPECT_FALSE(fs::exists(dir + "/kf-00000000.glb"));
    EXPECT_TRUE(fs::exists(dir + "/kf-00000000.r1.glb"));
    EXPECT_FALSE((*box)->coarsen(0, bytes(100, 4), 1, 1));  // a refinement is never coarsened
    EXPECT_EQ((*box)->entry(0)->bytes, 9000u);
  }
  std::ofstream(dir + "/kf-00000000.r2.glb") << "a second revision cut short before its JSON";
  std::ofstream(dir + "/kf-00000000.glb") << "the first revision, not yet removed";
  auto box = Outbox::open(dir, "m1");
  ASSERT_TRUE(box) << box.error().message;
  const auto e = *(*box)->entry(0);
  EXPECT_EQ(e.rev, 1);
  EXPECT_EQ(e.bytes, 9000u);
  EXPECT_EQ(e.first_bytes, 4000u);
  EXPECT_EQ(*(*box)->read_glb(0), bytes(9000, 3));
  EXPECT_FALSE(fs::exists(dir + "/kf-00000000.r2.glb"));
  EXPECT_FALSE(fs::exists(dir + "/kf-00000000.glb"));
  EXPECT_EQ((*box)->entry(1)->rev, 0);
  EXPECT_EQ(*(*box)->read_glb(1), bytes(4000, 2));
  test::remove_tree_quietly(dir);
}

// A revision beside the POST still out (Outbox::revise_in_flight): only an attempted, unanswered entry; the answers
// are kept for the revision they are about: rev 0's (after rev 1's, as when the server took rev 1 first) fills
// first_ack and does not touch rev 1's state; rev 0 cannot mark rev 1 attempted or rejected.
TEST(Outbox, AnEntryWhosePostIsOutIsRevisedBesideItAndEachAnswerKeepsToItsRevision) {
  const std::string dir = test::temp_dir("outbox_revise_in_flight");
  auto box = Outbox::open(dir, "m1");
  ASSERT_TRUE(box);
  ASSERT_TRUE((*box)->add(OutboxEntry{}, bytes(4000, 1)));
  EXPECT_FALSE((*box)->revise_in_flight(0, bytes(9000, 3), 90, 50));  // no POST out yet
  ASSERT_TRUE((*box)->mark_attempted(0, 12.0, 0));
  ASSERT_TRUE((*box)->revise_in_flight(0, bytes(9000, 3), 90, 50));
  auto e = *(*box)->entry(0);
  EXPECT_EQ(e.rev, 1);
  EXPECT_TRUE(e.pending());
  EXPECT_FALSE(e.attempted);
  EXPECT_EQ(e.first_bytes, 4000u);
  EXPECT_TRUE(e.first_ack.empty());
  EXPECT_DOUBLE_EQ(e.post_started, 12.0);
  EXPECT_FALSE((*box)->read_glb(0, 0));  // replaced: the POST out has its bytes
  EXPECT_EQ(*(*box)->read_glb(0, 1), bytes(9000, 3));
  // rev 0 can neither mark rev 1 attempted nor reject it.
  ASSERT_TRUE((*box)->mark_attempted(0, 13.0, 0));
  ASSERT_TRUE((*box)->mark_rejected(0, "too late", 0));
  EXPECT_FALSE((*box)->entry(0)->attempted);
  EXPECT_TRUE((*box)->entry(0)->rejected.empty());
  ASSERT_TRUE((*box)->mark_attempted(0, 14.0, 1));
  ASSERT_TRUE((*box)->mark_acked(0, R"({"seq":0,"rev":1})", 1));
  ASSERT_TRUE((*box)->mark_acked(0, R"({"seq":0,"rev":1,"stale":0})", 0));  // rev 0's answer, after rev 1's
  e = *(*box)->entry(0);
  EXPECT_TRUE(e.acked);
  EXPECT_EQ(e.rev, 1);
  EXPECT_EQ(e.ack_json, R"({"seq":0,"rev":1})");
  EXPECT_EQ(e.first_ack, R"({"seq":0,"rev":1,"stale":0})");
  EXPECT_FALSE((*box)->revise_in_flight(0, bytes(9500, 4), 95, 50));  // answered: revise() is for that
  test::remove_tree_quietly(dir);
}

TEST(Outbox, AGlbWithoutItsJsonIsRemovedAndItsSeqReused) {
  const std::string dir = test::temp_dir("outbox_orphan");
  {
    auto box = Outbox::open(dir, "m1");
    ASSERT_TRUE(box);
    ASSERT_TRUE((*box)->add(OutboxEntry{}, bytes(10, 1)));
  }
  std::ofstream(dir + "/kf-00000001.glb") << "half";  // a crash between the GLB and its JSON
  auto box = Outbox::open(dir, "m1");
  ASSERT_TRUE(box);
  EXPECT_FALSE(fs::exists(dir + "/kf-00000001.glb"));
  EXPECT_EQ((*box)->next_seq(), 1);
  test::remove_tree_quietly(dir);
}

// Deferred keyframes' records: they survive a reopen with what a later reduction needs, add() removes the record of
// the keyframe it adds, undefer() removes one (none there is no error), and a reopen removes a record whose frame
// already has an entry (a crash between the entry's JSON and the record's removal): deferred or added, never both.
TEST(Outbox, DeferredKeyframesSurviveAReopenAndGoWhenAdded) {
  const std::string dir = test::temp_dir("outbox_deferred");
  auto record = [](int frame) {
    DeferredKeyframe k;
    k.frame_index = frame;
    k.timestamp = 1305031102.5 + frame;
    k.pose = {0.1 * frame, 2, 3, 0, 0, 0.6, 0.8};
    k.captured = 1700000000.25 + frame;
    k.tracked = 1700000000.75 + frame;
    return k;
  };
  {
    auto box = Outbox::open(dir, "m1");
    ASSERT_TRUE(box) << box.error().message;
    ASSERT_TRUE((*box)->defer(record(20)));
    ASSERT_TRUE((*box)->defer(record(8)));
    ASSERT_TRUE((*box)->defer(record(14)));
    ASSERT_FALSE((*box)->defer(record(-1)));
    EXPECT_EQ((*box)->deferred().size(), 3u);
    OutboxEntry e;
    e.frame_index = 20;
    ASSERT_TRUE((*box)->add(e, bytes(100, 1)));
    EXPECT_FALSE(fs::exists(dir + "/deferred-00000020.json"));
    ASSERT_TRUE((*box)->undefer(14));
    ASSERT_TRUE((*box)->undefer(99));
  }
  {
    auto box = Outbox::open(dir, "m1");
    ASSERT_TRUE(box) << box.error().message;
    const auto waiting = (*box)->deferred();
    ASSERT_EQ(waiting.size(), 1u);
    EXPECT_EQ(waiting[0].frame_index, 8);
    EXPECT_DOUBLE_EQ(waiting[0].timestamp, 1305031110.5);
    EXPECT_DOUBLE_EQ(waiting[0].pose[0], 0.8);
    EXPECT_DOUBLE_EQ(waiting[0].pose[6], 0.8);
    EXPECT_DOUBLE_EQ(waiting[0].captured, 1700000008.25);
    EXPECT_DOUBLE_EQ(waiting[0].tracked, 1700000008.75);
    EXPECT_EQ((*box)->entries().size(), 1u);
    EXPECT_EQ((*box)->next_seq(), 1);  // a record takes no seq
  }
  // Frame 30 deferred, then added; its record put back as a crash between the entry and the removal leaves it.
  {
    auto box = Outbox::open(dir, "m1");
    ASSERT_TRUE(box);
    ASSERT_TRUE((*box)->defer(record(30)));
    ASSERT_TRUE(fs::exists(dir + "/deferred-00000030.json"));
    OutboxEntry e;
    e.frame_index = 30;
    ASSERT_TRUE((*box)->add(e, bytes(100, 2)));
  }
  std::ofstream(dir + "/deferred-00000030.json")
      << R"({"frame": 30, "timestamp": 0, "pose": [0,0,0,0,0,0,1], "captured": 1})";
  {
    auto box = Outbox::open(dir, "m1");
    ASSERT_TRUE(box) << box.error().message;
    const auto waiting = (*box)->deferred();
    ASSERT_EQ(waiting.size(), 1u);
    EXPECT_EQ(waiting[0].frame_index, 8);
    EXPECT_FALSE(fs::exists(dir + "/deferred-00000030.json"));
    EXPECT_EQ((*box)->entries().size(), 2u);
  }
  std::ofstream(dir + "/deferred-00000009.json") << "{not json";
  auto corrupt = Outbox::open(dir, "m1");
  ASSERT_FALSE(corrupt);
  EXPECT_EQ(corrupt.error().code, ErrorCode::kInvalidInput);
  test::remove_tree_quietly(dir);
}

TEST(Outbox, OneOutboxServesOneMission) {
  const std::string dir = test::temp_dir("outbox_mission");
  ASSERT_TRUE(Outbox::open(dir, "alpha"));
  auto other = Outbox::open(dir, "beta");
  ASSERT_FALSE(other);
  EXPECT_EQ(other.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(other.error().message.find("alpha"), std::string::npos);
  std::ofstream(dir + "/kf-00000000.json") << "{not json";
  auto corrupt = Outbox::open(dir, "alpha");
  ASSERT_FALSE(corrupt);
  EXPECT_EQ(corrupt.error().code, ErrorCode::kInvalidInput);
  test::remove_tree_quietly(dir);
}

TEST(Outbox, PoseQueryIsTumOrderWithAUnitQuaternion) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitY()).toRotationMatrix();
  m.block<3, 1>(0, 3) = Eigen::Vector3d(0.1, -0.2, 0.3);
  const auto p = pose_to_tum(m.data());
  EXPECT_DOUBLE_EQ(p[0], 0.1);
  EXPECT_DOUBLE_EQ(p[1], -0.2);
  EXPECT_DOUBLE_EQ(p[2], 0.3);
  EXPECT_NEAR(p[4], std::sin(0.25), 1e-12);
  EXPECT_NEAR(p[6], std::cos(0.25), 1e-12);
  EXPECT_EQ(pose_query({1, 2, 3, 0, 0, 0, 1}), "1,2,3,0,0,0,1");
}

}  // namespace
}  // namespace rgbdcast::stream
