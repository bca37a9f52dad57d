// stream/stream_policy.h: the stream's decisions, fed with snapshots, table by table. No thread, no clock, no file.
#include "stream/stream_policy.h"

#include <gtest/gtest.h>

#include <optional>
#include <string>
#include <vector>

namespace rgbdcast::stream {
namespace {

LinkSnapshot link_at(double line_kbps, double fixed_s = 0, size_t acks = 1) {
  LinkSnapshot l;
  l.line_kbps = line_kbps;
  l.post_fixed_s = fixed_s;
  l.acknowledged_posts = acks;
  return l;
}

OutboxEntry entry(int seq, size_t bytes, double budget_kb, bool acked, double captured) {
  OutboxEntry e;
  e.seq = seq;
  e.frame_index = 10 * seq;
  e.bytes = bytes;
  e.budget_kb = budget_kb;
  e.acked = acked;
  e.attempted = acked;
  e.captured = captured;
  return e;
}

// ---- The budget planner -------------------------------------------------------------------------------------------

TEST(BudgetPlanner, IsTheSmallerOfTheRateAndLatencyRulesAndADeferredKeyframeIsCoarsened) {
  const BudgetRule rule{4, 200, 0.9};
  LatencyRule latency;
  latency.target_s = 1.0;
  latency.first_post_fixed_s = 0.2;
  struct Case {
    std::string name;
    LinkSnapshot link;
    KeyframeBudgetInput in;
    double overhead_s, budget_kb;
  };
  LinkSnapshot two_lanes = link_at(1000, 0.1);
  two_lanes.lanes = 2;
  LinkSnapshot unanswered = link_at(1000, 0.1, 0);
  LinkSnapshot waited = link_at(1000, 0.1);
  waited.queue_wait_s = 0.2;
  // Rate rule: 1000 kbit/s = 125 kB/s x (interval x 0.9 - fixed). Latency rule: 125 kB/s x ((1 - overhead) x 0.9 -
  // fixed), the POST's share at least 0.25 s.
  const std::vector<Case> cases = {
      // 1 lane: rate 125 x (0.9 - 0.1) = 100 kB; latency overhead 0.3, 125 x (0.63 - 0.1) = 66.25 kB.
      {"one lane, latency rules", link_at(1000, 0.1), {1.0, 0.0, 0.3, false}, 0.3, 66.25},
      // A long interval: the rate rule allows 212.5 kB (ceiling 200), so latency's 66.25 kB rules.
      {"long interval", link_at(1000, 0.1), {2.0, 0.0, 0.3, false}, 0.3, 66.25},
      // A short interval: rate 125 x (0.45 - 0.1) = 43.75 kB rules.
      {"short interval", link_at(1000, 0.1), {0.5, 0.0, 0.3, false}, 0.3, 43.75},
      // 2 lanes: the rate rule counts no fixed cost: 125 x 0.45 = 56.25 kB.
      {"two lanes", two_lanes, {0.5, 0.0, 0.3, false}, 0.3, 56.25},
      // Before any answer the overhead has first_post_fixed_s: 0.5; 125 x (0.45 - 0.1) = 43.75 kB.
      {"no answer yet", unanswered, {1.0, 0.0, 0.3, false}, 0.5, 43.75},
      // Age and the outbox wait count: overhead 0.4 + 0.3 + 0.2 = 0.9; the share floor 0.25 s: 125 x (0.225 - 0.1).
      {"old keyframe", waited, {1.0, 0.4, 0.3, false}, 0.9, 15.625},
      // Deferred: a quarter of the rate rule (100 kB), the latency rule not applied.
      {"deferred", link_at(1000, 0.1), {1.0, 5.0, 0.3, true}, 5.3, 25.0},
      // Deferred on a slow link: not below the floor.
      {"deferred at the floor", link_at(50, 0.1), {1.0, 0.0, 0.3, true}, 0.3, 4.0},
  };
  for (const Case& c : cases) {
    const KeyframeBudget b = plan_keyframe_budget(c.link, c.in, rule, latency, 0.25);
    EXPECT_NEAR(b.overhead_s, c.overhead_s, 1e-9) << c.name;
    EXPECT_NEAR(b.budget_kb, c.budget_kb, 1e-9) << c.name;
  }
}

TEST(BudgetPlanner, ARefinementGoesBesideTheFirstKeyframeOnlyUnderACapBeforeAnyAnswerWhenItBeatsIt) {
  const RefineLimits limits{200, 1.0, 0.9};
  LinkSnapshot capped = link_at(2000, 0, 0);
  capped.cap_kbps = 2000;  // 250 kB/s x 0.9 = 225 kB, at most 200
  capped.refinements_yield = true;
  struct Case {
    std::string name;
    LinkSnapshot link;
    double keyframe_kb;
    bool deferred;
    std::optional<double> expected;
  };
  LinkSnapshot answered = capped;
  answered.acknowledged_posts = 1;
  LinkSnapshot no_cap = capped;
  no_cap.cap_kbps = 0;
  LinkSnapshot one_lane = capped;
  one_lane.refinements_yield = false;
  LinkSnapshot slow = capped;
  slow.cap_kbps = 100;  // 12.5 kB/s x 0.9 = 11.25 kB
  const std::vector<Case> cases = {
      {"under a cap, first keyframe", capped, 40, false, 200.0},
      {"deferred", capped, 40, true, std::nullopt},
      {"after an answer", answered, 40, false, std::nullopt},
      {"no cap", no_cap, 40, false, std::nullopt},
      {"refinements do not yield", one_lane, 40, false, std::nullopt},
      {"does not beat it by 8 kB", slow, 4, false, std::nullopt},
      {"does not beat it by 1.25 x", capped, 170, false, std::nullopt},
  };
  for (const Case& c : cases) {
    EXPECT_EQ(beside_keyframe_budget_kb(c.link, limits, c.keyframe_kb, c.deferred), c.expected) << c.name;
  }
  EXPECT_TRUE(refine_right_after_keyframe(capped, true, true));
  EXPECT_FALSE(refine_right_after_keyframe(capped, false, true));   // nothing written
  EXPECT_FALSE(refine_right_after_keyframe(capped, true, false));   // a keyframe waits
  EXPECT_FALSE(refine_right_after_keyframe(answered, true, true));  // the link is measured
  EXPECT_FALSE(refine_right_after_keyframe(one_lane, true, true));
}

// ---- The backlog rule ---------------------------------------------------------------------------------------------

TEST(BacklogRule, AKeyframeIsHeldWhileTheLinkOwesMoreThanItsReductionTakes) {
  struct Case {
    bool supersede;
    double owed_s, reduce_s;
    bool hold;
  };
  const std::vector<Case> cases = {
      {true, 0.0, 0.3, false}, {true, 0.3, 0.3, false},
      {true, 0.31, 0.3, true}, {true, 0.1, 0.0, false},   // at least 0.1 s
      {true, 0.11, 0.0, true}, {false, 5.0, 0.3, false},  // supersede off: never held
  };
  for (const Case& c : cases)
    EXPECT_EQ(hold_keyframe(c.supersede, c.owed_s, c.reduce_s), c.hold) << c.owed_s << " " << c.reduce_s;
}

TEST(BacklogRule, TheNewestGoesFirstOlderOnesAreDeferredAndReducedNewestFirstAndTheOldestBeyondTheLimitDropped) {
  KeyframeQueues<int> q(2);
  for (int frame : {10, 20, 30, 40}) q.push(frame);
  auto held = q.hold();
  EXPECT_EQ(held.deferred_now, (std::vector<int>{10, 20, 30}));
  EXPECT_EQ(held.dropped, (std::vector<int>{10}));  // max 2 deferred: the oldest goes
  EXPECT_EQ(q.waiting(), 1u);
  EXPECT_EQ(q.deferred(), 2u);
  q.push(50);  // tracked while held: the next hold defers 40
  held = q.hold();
  EXPECT_EQ(held.deferred_now, (std::vector<int>{40}));
  EXPECT_EQ(held.dropped, (std::vector<int>{20}));
  // The link has room: the waiting keyframe first, then the deferred ones newest first.
  std::vector<std::pair<int, bool>> order;
  while (auto next = q.take()) order.push_back(*next);
  EXPECT_EQ(order, (std::vector<std::pair<int, bool>>{{50, false}, {40, true}, {30, true}}));
  EXPECT_TRUE(q.empty());
}

TEST(BacklogRule, WithoutRealtimeTheTrackerWaitsForTheReductionUnlessTheKeyframeIsHeldBack) {
  struct Case {
    bool holding;
    size_t waiting;
    bool reducing, goes_on;
  };
  const std::vector<Case> cases = {
      {false, 0, false, true},  // nothing left to reduce
      {false, 1, false, false}, {false, 0, true, false},
      {false, 2, true, false},  {true, 1, false, true},  // held back: a newer keyframe may supersede it
      {true, 0, true, true},
  };
  for (const Case& c : cases)
    EXPECT_EQ(tracker_may_go_on(c.holding, c.waiting, c.reducing), c.goes_on)
        << c.holding << " " << c.waiting << " " << c.reducing;
}

TEST(BacklogRule, ResumedDeferredKeyframesBeyondTheLimitAreTrimmedOldestFirst) {
  KeyframeQueues<int> q(1);
  for (int frame : {10, 20, 30}) q.push_deferred(frame);
  EXPECT_EQ(q.trim(), (std::vector<int>{10, 20}));
  auto next = q.take();
  ASSERT_TRUE(next);
  EXPECT_EQ(*next, std::make_pair(30, true));
}

TEST(BacklogRule, CoarsensTheOldestNeverAttemptedKeyframesUntilTheBacklogFits) {
  // 100 kbit/s: 12.5 kB a second; the limit is max(2 s, 2 x 0.5 s) = 2 s = 25 kB.
  std::vector<OutboxEntry> all = {entry(0, 20000, 40, false, 1), entry(1, 20000, 40, false, 2),
                                  entry(2, 20000, 40, false, 3), entry(3, 20000, 40, false, 4)};
  all[0].attempted = true;  // on the line: its bytes never change
  all[1].coarsened = true;  // coarsened once already
  CoarsenPlan plan(all, 3, 100, 0.5, {2.0, 0.25, 4});
  EXPECT_NEAR(plan.backlog_s(), 80000 * 8 / 1000.0 / 100, 1e-9);
  EXPECT_NEAR(plan.limit_s(), 2.0, 1e-12);
  auto step = plan.next();
  ASSERT_TRUE(step);
  EXPECT_EQ(step->seq, 2);  // the newest (3) never, 0 and 1 not again
  EXPECT_NEAR(step->target_kb, 10, 1e-12);
  plan.shrunk_by(10000);
  EXPECT_FALSE(plan.next());  // none left

  // It stops as soon as the backlog fits; with a 1.6 s interval the limit is 3.2 s.
  std::vector<OutboxEntry> fresh = {entry(0, 15000, 40, false, 1), entry(1, 15000, 40, false, 2),
                                    entry(2, 15000, 40, false, 3)};
  CoarsenPlan fits(fresh, 2, 300, 1.6, {2.0, 0.25, 4});  // 45 kB at 37.5 kB/s = 1.2 s
  EXPECT_NEAR(fits.limit_s(), 3.2, 1e-12);
  EXPECT_FALSE(fits.next());
  CoarsenPlan over(fresh, 2, 100, 1.6, {2.0, 0.25, 4});  // 45 kB at 12.5 kB/s = 3.6 s
  step = over.next();
  ASSERT_TRUE(step);
  EXPECT_EQ(step->seq, 0);
  over.shrunk_by(5000);  // 40 kB: 3.2 s, fits
  EXPECT_FALSE(over.next());
  // An entry already about as small as its target is left alone, and the floor holds.
  std::vector<OutboxEntry> small = {entry(0, 4400, 16, false, 1), entry(1, 60000, 8, false, 2),
                                    entry(2, 20000, 40, false, 3)};
  CoarsenPlan floor(small, 2, 100, 0.5, {2.0, 0.25, 4});
  step = floor.next();
  ASSERT_TRUE(step);
  EXPECT_EQ(step->seq, 1);
  EXPECT_NEAR(step->target_kb, 4, 1e-12);
}

// ---- The refinement planner ---------------------------------------------------------------------------------------

TEST(RefinementPlanner, ChoosesTheNewestAcknowledgedKeyframeTheBudgetBeatsAndRemembersWhatItTried) {
  RefinementPlanner planner({200, 1.0, 0.9}, 40);
  // 1000 kbit/s, fixed 0.1 s: 125 x (0.9 - 0.1) = 100 kB in a 1 s window.
  const LinkSnapshot link = link_at(1000, 0.1);
  std::vector<OutboxEntry> all = {entry(0, 30000, 30, true, 1), entry(1, 30000, 30, true, 3),
                                  entry(2, 30000, 90, true, 5), entry(3, 30000, 30, false, 6)};
  auto r = planner.choose(all, link, {1.0, false, -1});
  ASSERT_TRUE(r.chosen);
  EXPECT_EQ(r.chosen->entry.seq, 1);  // 2 is newer but 100 kB does not beat 90; 3 is not answered
  EXPECT_NEAR(r.chosen->budget_kb, 100, 1e-9);
  EXPECT_FALSE(r.chosen->made_ahead);
  // Tried at 100 kB: not again at that budget; the next one is 0.
  r = planner.choose(all, link, {1.0, false, -1});
  ASSERT_TRUE(r.chosen);
  EXPECT_EQ(r.chosen->entry.seq, 0);
  EXPECT_FALSE(planner.choose(all, link, {1.0, false, -1}).chosen);
  // Forgotten (its refinement is to be made again): 1 again, the newest.
  planner.forget_tried(1);
  r = planner.choose(all, link, {1.0, false, -1});
  ASSERT_TRUE(r.chosen);
  EXPECT_EQ(r.chosen->entry.seq, 1);
  // A smaller window (43.75 kB) beats nothing tried.
  EXPECT_FALSE(planner.choose(all, link, {0.5, false, -1}).chosen);
}

TEST(RefinementPlanner, AheadAKeyframeWhosePostIsOutQualifiesOnlyOnceTheLinkIsMeasuredOrUnderACap) {
  std::vector<OutboxEntry> out = {entry(0, 30000, 30, false, 1)};
  out[0].attempted = true;
  struct Case {
    std::string name;
    LinkSnapshot link;
    bool ahead;
    bool chosen;
    double budget_kb;
    bool from_cap;
  };
  LinkSnapshot guess = link_at(1000, 0.1, 0);  // no answer yet, no cap
  LinkSnapshot capped = link_at(1000, 0.1, 0);
  capped.cap_kbps = 2000;  // the cap's budget: 250 x 0.9 = 225, at most 200
  LinkSnapshot down = link_at(1000, 0.1);
  down.link_down = true;
  const std::vector<Case> cases = {
      {"measured, ahead", link_at(1000, 0.1), true, true, 100, false},
      {"measured, not ahead", link_at(1000, 0.1), false, false, 0, false},
      {"initial guess, no cap", guess, true, false, 0, false},
      {"under a cap before any answer", capped, true, true, 200, true},
      {"the link is down", down, true, false, 0, false},
  };
  for (const Case& c : cases) {
    RefinementPlanner planner({200, 1.0, 0.9}, 40);
    auto r = planner.choose(out, c.link, {1.0, c.ahead, -1});
    ASSERT_EQ(r.chosen.has_value(), c.chosen) << c.name;
    if (!r.chosen) continue;
    EXPECT_TRUE(r.chosen->made_ahead) << c.name;
    EXPECT_EQ(r.chosen->made_from_cap, c.from_cap) << c.name;
    EXPECT_NEAR(r.chosen->budget_kb, c.budget_kb, 1e-9) << c.name;
  }
  // Under a cap, a keyframe just added qualifies before its lane marks it attempted; a rejected one never.
  std::vector<OutboxEntry> fresh = {entry(0, 30000, 30, false, 1)};
  RefinementPlanner planner({200, 1.0, 0.9}, 40);
  EXPECT_TRUE(planner.choose(fresh, capped, {1.0, true, 0}).chosen);
  fresh[0].rejected = "refused";
  RefinementPlanner again({200, 1.0, 0.9}, 40);
  EXPECT_FALSE(again.choose(fresh, capped, {1.0, true, 0}).chosen);
}

TEST(RefinementPlanner, ARevisionThatFitsItsBudgetIsNotRefinedAtTheSameSettingsButIsAtFinerOnes) {
  const LinkSnapshot link = link_at(1000, 0.1);  // 100 kB in a 1 s window
  struct Case {
    std::string name;
    double fine_above_kb, fit_budget_kb;
    bool fits;
    bool chosen;
  };
  const std::vector<Case> cases = {
      {"fit, both above the fine threshold", 40, 60, true, false},
      {"fit below, refinement above: finer settings", 80, 60, true, true},
      {"fine settings off: always the same", 0, 60, true, false},
      {"did not fit", 40, 60, false, true},
  };
  for (const Case& c : cases) {
    RefinementPlanner planner({200, 1.0, 0.9}, c.fine_above_kb);
    std::vector<OutboxEntry> all = {entry(0, 50000, c.fit_budget_kb, true, 1)};
    planner.note_revision(0, 50000, c.fit_budget_kb, c.fits);
    auto r = planner.choose(all, link, {1.0, false, -1});
    EXPECT_EQ(r.chosen.has_value(), c.chosen) << c.name;
    EXPECT_EQ(r.newly_saturated, c.chosen ? 0u : 1u) << c.name;
    if (!c.chosen) {
      EXPECT_EQ(planner.choose(all, link, {1.0, false, -1}).newly_saturated, 0u) << "counted once";
    }
  }
  // A revision that changed since it fit (other bytes) is not saturated.
  RefinementPlanner planner({200, 1.0, 0.9}, 40);
  planner.note_revision(0, 40000, 60, true);
  EXPECT_FALSE(planner.saturated(entry(0, 50000, 60, true, 1), 100));
}

TEST(RefinementPlanner, ARefinementIsKeptAt125TimesTheBytesAndOneSizedToTheCapOnlyIfTheMeasuredLinkCarriesIt) {
  struct Case {
    size_t bytes, replaced;
    bool from_cap, answered;
    double measured_kb;
    RefinementVerdict verdict;
  };
  const std::vector<Case> cases = {
      {125000, 100000, false, true, 0, RefinementVerdict::kKeep},
      {124999, 100000, false, true, 0, RefinementVerdict::kTooSmall},
      {133000, 25000, true, false, 60, RefinementVerdict::kKeep},  // not answered yet: not checked
      {133000, 25000, true, true, 60, RefinementVerdict::kRedoMeasured},
      {59000, 25000, true, true, 60, RefinementVerdict::kKeep},
      {133000, 25000, false, true, 60, RefinementVerdict::kKeep},  // measured already when sized
  };
  for (const Case& c : cases)
    EXPECT_EQ(judge_refinement(c.bytes, c.replaced, c.from_cap, c.answered, c.measured_kb), c.verdict) << c.bytes;
}

TEST(RefinementPlanner, TheRefinerWindowEndsWhenTheNextKeyframesPostIsExpectedUnlessRefinementsYield) {
  LinkSnapshot link = link_at(1000);
  // Last keyframe at 10 s, interval 1 s, its reduction 0.3 s, this refinement's 0.5 s: until 10.8 s.
  EXPECT_NEAR(refiner_window_s(link, 1.0, 10.0, 1.0, 0.3, 0.5, 10.2), 0.6, 1e-9);
  EXPECT_LE(refiner_window_s(link, 1.0, 10.0, 1.0, 0.3, 0.5, 10.9), 0.0);
  link.refinements_yield = true;
  EXPECT_NEAR(refiner_window_s(link, 1.0, 10.0, 1.0, 0.3, 0.5, 10.9), 1.0, 1e-12);
  // The drain refines once the link owes no more than a refinement takes (at least 0.1 s).
  EXPECT_TRUE(link_has_room(0.5, 0.5));
  EXPECT_FALSE(link_has_room(0.51, 0.5));
  EXPECT_TRUE(link_has_room(0.1, 0.0));
}

TEST(RefinementPlanner, TheRefinerTakesItsTurnOnlyWithNoKeyframeWorkAWindowAndALinkThatOwesAlmostNothing) {
  struct Case {
    std::string name;
    RefinerTurn turn;
    bool refines;
  };
  const std::vector<Case> cases = {
      {"idle", {false, 1, 0.5, 0.0}, true},
      {"owes exactly the threshold", {false, 1, 0.5, kRefinerOwedS}, true},
      {"owes more", {false, 1, 0.5, kRefinerOwedS + 0.01}, false},
      {"a keyframe waits, is reduced or held", {true, 1, 0.5, 0.0}, false},
      {"no keyframe written yet", {false, 0, 0.5, 0.0}, false},
      {"the window is over", {false, 3, 0.0, 0.0}, false},
  };
  for (const Case& c : cases) EXPECT_EQ(refiner_may_refine(c.turn), c.refines) << c.name;
}

// An entry whose POST of revision `rev` is out, and what its answer or a newer revision makes of it.
struct EntryStates {
  OutboxEntry out, answered, revised, rejected;
};
EntryStates states_of(int seq, int rev) {
  EntryStates s;
  s.out = entry(seq, 20000, 20, false, 1);
  s.out.attempted = true;
  s.out.rev = rev;
  s.answered = s.out;
  s.answered.acked = true;
  s.revised = s.out;
  s.revised.rev = rev + 1;
  s.rejected = s.out;
  s.rejected.rejected = "refused";
  return s;
}

TEST(RefinementPlanner, ARefinementFromTheCapGoesBesideItsKeyframesPostOnceStartedAndUnanswered) {
  const auto [out, answered, revised, rejected] = states_of(4, 0);
  OutboxEntry waiting = out;
  waiting.attempted = false;
  struct Case {
    std::string name;
    std::optional<OutboxEntry> now;
    bool settled, beside;
  };
  const std::vector<Case> cases = {
      {"not started: wait", waiting, false, false}, {"its POST is out", out, true, true},
      {"answered already", answered, true, false},  {"another revision", revised, true, false},
      {"rejected", rejected, true, false},          {"removed", std::nullopt, true, false},
  };
  for (const Case& c : cases) {
    EXPECT_EQ(post_start_settled(c.now, 0), c.settled) << c.name;
    EXPECT_EQ(revise_beside_post(c.now, 0), c.beside) << c.name;
  }
}

TEST(RefinementPlanner, ARefinementMadeAheadWaitsForItsAnswerUnlessTheEntryChangedTheRunStopsOrTheLinkIsDown) {
  const auto [out, answered, newer, rejected] = states_of(2, 1);
  struct Case {
    std::string name;
    AheadSnapshot s;
    AheadStep step;
  };
  const std::vector<Case> cases = {
      {"answered", {answered, 1, true, false, false}, AheadStep::kAdd},
      {"answered while stopping", {answered, 1, true, true, true}, AheadStep::kAdd},
      {"out", {out, 1, true, false, false}, AheadStep::kWait},
      {"out, stopping", {out, 1, true, true, false}, AheadStep::kDrop},
      {"out, the link is down", {out, 1, true, false, true}, AheadStep::kRedoLater},
      {"rejected", {rejected, 1, true, false, false}, AheadStep::kDrop},
      {"revised meanwhile", {newer, 1, true, false, false}, AheadStep::kDrop},
      {"removed", {std::nullopt, 1, true, false, false}, AheadStep::kDrop},
      // The reduction thread does not wait: answered, added; anything else, made again later.
      {"no wait, answered", {answered, 1, false, false, false}, AheadStep::kAdd},
      {"no wait, out", {out, 1, false, false, false}, AheadStep::kRedoLater},
      {"no wait, revised meanwhile", {newer, 1, false, false, false}, AheadStep::kRedoLater},
      {"no wait, removed", {std::nullopt, 1, false, false, false}, AheadStep::kRedoLater},
  };
  for (const Case& c : cases) EXPECT_EQ(refinement_ahead_step(c.s), c.step) << c.name;
}

// ---- Resume -------------------------------------------------------------------------------------------------------

TEST(Resume, RestartsAtTheLatestKeyframesFrameOverEntriesAndDeferredRecords) {
  auto posed = [](OutboxEntry e, double x) {
    e.pose = {x, 0, 0, 0, 0, 0, 1};
    return e;
  };
  DeferredKeyframe late;
  late.frame_index = 70;
  late.pose = {7, 0, 0, 0, 0, 0, 1};
  DeferredKeyframe early;
  early.frame_index = 5;
  early.pose = {0.5, 0, 0, 0, 0, 0, 1};
  OutboxEntry rejected = posed(entry(2, 1000, 10, false, 3), 2);
  rejected.rejected = "refused";
  // A deferred keyframe reduced after the outage: seq 3 but frame 15, older than seq 2's frame 20.
  OutboxEntry after_outage = posed(entry(3, 1000, 10, false, 4), 1.5);
  after_outage.frame_index = 15;
  struct Case {
    std::string name;
    std::vector<OutboxEntry> entries;
    std::vector<DeferredKeyframe> deferred;
    bool resumed;
    int at_frame;
    double anchor_x;
    std::vector<int> views;
  };
  const std::vector<Case> cases = {
      {"empty outbox", {}, {}, false, -1, 0, {}},
      {"entries",
       {posed(entry(0, 1000, 10, true, 1), 0), posed(entry(1, 1000, 10, true, 2), 1)},
       {},
       true,
       10,
       1,
       {0, 1}},
      {"a higher seq with an older frame",
       {posed(entry(1, 1000, 10, true, 2), 1), rejected, after_outage},
       {},
       true,
       20,
       2,
       {1, 3}},
      {"a deferred record is the latest", {posed(entry(1, 1000, 10, true, 2), 1)}, {early, late}, true, 70, 7, {1}},
      {"only deferred records", {}, {early}, true, 5, 0.5, {}},
  };
  for (const Case& c : cases) {
    const ResumePlan p = plan_resume(c.entries, c.deferred);
    EXPECT_EQ(p.resumed, c.resumed) << c.name;
    EXPECT_EQ(p.at_frame, c.at_frame) << c.name;
    EXPECT_NEAR(p.anchor[0], c.anchor_x, 1e-12) << c.name;
    EXPECT_EQ(p.anchor[6], 1.0) << c.name;
    EXPECT_EQ(p.view_seqs, c.views) << c.name;
  }
}

}  // namespace
}  // namespace rgbdcast::stream
