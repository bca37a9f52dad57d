// stream/keyframe_stream.h's refinements of a keyframe whose first POST is still out, end to end in-process: the real
// reduction of augmented ICL frame 0 (one keyframe, as the benchmark's ICL input makes), a real Sender, and the
// tests' mission server on the service's MissionStore (fake_mission_server.h), which keeps the highest revision of a
// keyframe whichever comes first and answers an older one 409 stale_revision, as the service does. The first
// revision's answer comes 1.5 s after its body (so the refinement's reduction is done long before), a refinement's
// at once. What happens before that answer depends on the cap and the lanes: under a cap with three lanes
// (refinements yield to keyframes) the refinement is reduced at once at the cap's budget and posted beside the first
// POST (there the first answer is held until the refinement is stored, so the order does not depend on the
// machine's speed); under a cap with one lane it is reduced ahead and added when the answer comes if the measured
// link carries it (else made again at the measured budget); without a cap it waits for the answer. The cases assert
// order and counts, not how long anything took.
#include <gtest/gtest.h>

#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <thread>

#include "input/frame_source.h"
#include "pipeline/frame_defaults.h"
#include "stream/keyframe_stream.h"
#include "tests/common/test_data.h"
// After Eigen (through the frame source): httplib's macros break Eigen's headers included after it.
#include "tests/stream/fake_mission_server.h"

namespace rgbdcast::stream {
namespace {

constexpr const char* kIcl = "augmented_icl_livingroom";
constexpr double kAnswerDelayS = 1.5;  // the first revision's answer, after its body was read
constexpr double kWindowS = 4;         // --refine-window-ms (larger than the answer's delay: see the cases)

struct AheadRun {
  StreamSummary summary;
  std::vector<PostRecord> log;
  std::optional<OutboxEntry> first;           // the keyframe's entry at the end
  std::map<int, int> stored_rev;              // seq -> the revision the server holds
  std::map<std::pair<int, int>, int> stored;  // (seq, rev) -> times created
  std::map<std::pair<int, int>, size_t> stored_bytes;
  int stale = 0;  // POSTs answered 409 stale_revision
};

// Streams ICL frame 0 to the server above over `lanes` connections; cap_kbps 0: no cap. initial_fixed_s is the POST
// model's first fixed cost (rgbdcast stream measures it with a bodiless request): at the answer's delay the first
// answer measures a fast line, at 0 a slow one (25 kB in 1.5 s). hold_until_refined: the first revision's answer
// waits for the refinement to be stored instead of the delay.
void stream_one_keyframe(double cap_kbps, double initial_fixed_s, size_t lanes, AheadRun& out,
                         bool hold_until_refined = false) {
  auto source = open_frame_source(test::data_path(kIcl), SourceOptions{});
  ASSERT_TRUE(source) << source.error().message;
  const std::string dir = test::temp_dir("refine_ahead");
  auto box = Outbox::open(dir, "ahead");
  ASSERT_TRUE(box);

  test::FakeMissionServer::Script script;
  script.hold = [hold_until_refined](test::FakeMissionServer& server, const test::ServedPost& post) {
    if (post.rev != 0) return;
    if (!hold_until_refined) {
      std::this_thread::sleep_for(std::chrono::duration<double>(kAnswerDelayS));
      return;
    }
    server.wait_until([&post](const std::vector<test::ServedPost>& posts) {
      for (const test::ServedPost& p : posts)
        if (p.seq == post.seq && p.rev > 0 && p.answer_step >= 0) return true;
      return false;
    });
  };
  test::FakeMissionServer server(script);
  const int port = server.start();
  ASSERT_GT(port, 0);

  std::vector<std::unique_ptr<Uplink>> owned;
  std::vector<Uplink*> uplinks;
  UplinkOptions uo;
  uo.server_url = server.url();
  for (size_t i = 0; i < lanes; ++i) {
    auto uplink = Uplink::create(uo);
    ASSERT_TRUE(uplink);
    owned.push_back(std::move(*uplink));
    uplinks.push_back(owned.back().get());
  }
  SenderParams sp;
  sp.mission = "ahead";
  sp.link.cap_kbps = cap_kbps;
  sp.link.initial_fixed_s = initial_fixed_s;
  sp.max_first_in_flight = lanes > 1 ? lanes - 1 : 0;  // as rgbdcast stream: refinements get a lane more
  Sender sender(**box, uplinks, sp);

  StreamOptions o;
  o.reduction.params = reduction_preset(Preset::kRealtime);
  o.reduction.glb.geometry_codec = default_geometry_codec(Preset::kRealtime);
  o.sequence.to = 0;  // frame 0 alone: one keyframe
  o.refine_window_s = kWindowS;
  o.refine_while_tracking = false;  // the drain's refinements alone
  auto summary = run_stream(**source, **box, sender, o, nullptr, [] { return false; });
  sender.stop();
  uplinks.clear();
  owned.clear();  // closed: the server stops at once, not after its keep-alive timeout
  server.stop();
  ASSERT_TRUE(summary) << summary.error().message;
  EXPECT_EQ(server.held_too_long(), 0);
  out.summary = *summary;
  out.log = sender.post_log();
  out.first = (*box)->entry(0);
  for (const service::MissionKeyframe& k : server.keyframes("ahead"))
    out.stored_rev[static_cast<int>(k.seq)] = static_cast<int>(k.rev);
  for (const test::ServedPost& p : server.posts()) {
    if (p.status == 201) {
      ++out.stored[{p.seq, p.rev}];
      out.stored_bytes[{p.seq, p.rev}] = p.bytes;
    }
    out.stale += p.error == "stale_revision";
  }
  test::remove_tree_quietly(dir);
}

// When the refinement's POST started, from the first revision's answer (negative: before it).
double revision_started_after_answer_s(const AheadRun& run) {
  double answered = 0, started = 0;
  for (const PostRecord& p : run.log) {
    if (p.rev == 0 && p.stored) answered = p.ended;
    if (p.rev == 1) started = p.started;
  }
  EXPECT_GT(answered, 0);
  EXPECT_GT(started, 0);
  return started - answered;
}

// One refinement, added as expected: `ahead` (reduced before the first answer) and `redone` (made ahead, then
// again for the measured link) as the summary counts them; the keyframe at rev 1, acknowledged, and the server
// holding rev 1, stored once with the outbox's bytes.
void expect_one_refinement(const AheadRun& run, size_t ahead, size_t redone) {
  EXPECT_EQ(run.summary.keyframes, 1u);
  EXPECT_EQ(run.summary.refined, 1u);
  EXPECT_EQ(run.summary.refined_ahead, ahead);
  EXPECT_EQ(run.summary.refined_ahead_redone, redone);
  ASSERT_TRUE(run.first);
  EXPECT_EQ(run.first->rev, 1);
  EXPECT_TRUE(run.first->acked);
  EXPECT_EQ(run.stored_rev.at(0), 1);
  EXPECT_EQ(run.stored.at({0, 1}), 1);
  EXPECT_EQ(run.stored_bytes.at({0, 1}), run.first->bytes);
}

}  // namespace

// Under a cap of 2 Mbit/s with three lanes: the refinement is reduced as soon as the keyframe is written, at what the
// cap carries in the window (the ceiling, 200 kB), and posted beside the first POST, before its answer. The server
// takes rev 1 first here (rev 0's answer is slow), so rev 0 is answered 409 stale_revision, which the sender resolves
// as stored (reading the mission back); its answer becomes the entry's first_ack.
TEST(KeyframeStream, UnderACapTheRefinementIsPostedBesideTheFirstPostBeforeItsAnswer) {
  REQUIRE_DATA(kIcl);
  AheadRun run;
  stream_one_keyframe(2000, kAnswerDelayS, 3, run, /*hold_until_refined=*/true);
  if (HasFatalFailure()) return;
  expect_one_refinement(run, 1, 0);
  ASSERT_TRUE(run.first);
  EXPECT_DOUBLE_EQ(run.first->budget_kb, refinement_budget_kb(2000, kWindowS, 0, 200, 0.9));
  EXPECT_DOUBLE_EQ(run.first->budget_kb, 200);
  EXPECT_EQ(run.summary.refined_while_tracking, 1u);   // made on the reduction thread, before the drain
  EXPECT_EQ(run.summary.refined_beside_keyframe, 1u);  // reduced beside the keyframe itself, not after it
  EXPECT_LT(revision_started_after_answer_s(run), 0);  // before: rev 0's answer waited for it to be stored
  EXPECT_EQ(run.stale, 1);
  EXPECT_EQ(run.stored.count({0, 0}), 0u);
  EXPECT_FALSE(run.first->first_ack.empty());
  EXPECT_EQ(run.summary.sender.rejected, 0u);
  EXPECT_EQ(run.summary.sender.posts, 2u);
}

// The same cap with one lane (a refinement does not yield to keyframes there): the refinement is reduced while the
// first POST is out and posted as soon as its answer comes, since the measured line carries it in the window.
TEST(KeyframeStream, UnderACapWithOneLaneTheRefinementIsReducedAheadAndPostedWhenTheAnswerComes) {
  REQUIRE_DATA(kIcl);
  AheadRun run;
  stream_one_keyframe(2000, kAnswerDelayS, 1, run);
  if (HasFatalFailure()) return;
  expect_one_refinement(run, 1, 0);
  EXPECT_EQ(run.summary.refined_beside_keyframe, 0u);  // one lane: refinements do not yield, none goes beside
  ASSERT_TRUE(run.first);
  EXPECT_DOUBLE_EQ(run.first->budget_kb, 200);
  EXPECT_EQ(run.stored.at({0, 0}), 1);
  // Its POST followed the answer (it was reduced ahead: refined_ahead above, not reduced after the answer).
  EXPECT_GE(revision_started_after_answer_s(run), 0);
}

// One lane, the same cap, but the first answer measures a slow line (25 kB in 1.5 s: about 60 kB in the window):
// the revision made ahead at the cap's budget (about 133 kB) is too large for it, so it is dropped and the keyframe
// refined again at the measured budget, as it is without a cap. (That smaller revision is answered at once, which
// raises the estimate: a further refinement may follow, as it would without a cap.)
TEST(KeyframeStream, ARefinementMadeAheadThatTheMeasuredLinkCannotCarryIsMadeAgainSmaller) {
  REQUIRE_DATA(kIcl);
  AheadRun run;
  stream_one_keyframe(2000, 0, 1, run);
  if (HasFatalFailure()) return;
  EXPECT_GE(run.summary.refined, 1u);
  EXPECT_EQ(run.summary.refined_ahead, 0u);
  EXPECT_EQ(run.summary.refined_ahead_redone, 1u);
  ASSERT_TRUE(run.first);
  EXPECT_TRUE(run.first->acked);
  EXPECT_EQ(run.first->rev, static_cast<int>(run.summary.refined));
  ASSERT_EQ(run.stored.count({0, 1}), 1u);
  EXPECT_EQ(run.stored.at({0, 1}), 1);
  EXPECT_LT(run.stored_bytes.at({0, 1}), 100000u);  // rev 1 is the revision made for the measured link
  EXPECT_GE(run.stored_bytes.at({0, 1}), stream::kRefinementKeepRatio * run.first->first_bytes);
}

// Without a cap nothing changes (three lanes, as rgbdcast stream): before the first answer there is no budget to
// trust, so the refinement is reduced after it, at the measured budget, and posted after it.
TEST(KeyframeStream, WithoutACapTheRefinementWaitsForTheFirstAnswer) {
  REQUIRE_DATA(kIcl);
  AheadRun run;
  stream_one_keyframe(0, kAnswerDelayS, 3, run);
  if (HasFatalFailure()) return;
  expect_one_refinement(run, 0, 0);
  EXPECT_EQ(run.summary.refined_beside_keyframe, 0u);
  EXPECT_EQ(run.stored.at({0, 0}), 1);
  EXPECT_EQ(run.stale, 0);
  EXPECT_GT(revision_started_after_answer_s(run), 0);
}

}  // namespace rgbdcast::stream
