// The link estimate, the keyframe budget that follows it, and the retry backoff (stream/link_estimator.h,
// stream/backoff.h).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>

#include "tests/common/test_data.h"

#include "stream/backoff.h"
#include "stream/link_estimator.h"

namespace rgbdcast::stream {
namespace {

// A link of `kbps` that acknowledges a POST of `bytes` after bytes / rate plus a round trip.
double post_seconds(size_t bytes, double kbps, double rtt_s) { return bytes * 8.0 / 1000.0 / kbps + rtt_s; }

TEST(LinkEstimator, StartsAtTheCapAndConvergesToTheAcknowledgedRate) {
  LinkEstimatorParams p;
  p.cap_kbps = 2000;
  LinkEstimator e(p);
  EXPECT_DOUBLE_EQ(e.estimate_kbps(), 500);  // the initial guess is below the cap
  for (int i = 0; i < 20; ++i) e.on_ack(20000, post_seconds(20000, 400, 0.0));
  EXPECT_NEAR(e.estimate_kbps(), 400, 1);
  // 20 kB in 0.4 s + 0.1 s round trip: goodput 320 kbit/s, which is what the estimate reports.
  for (int i = 0; i < 30; ++i) e.on_ack(20000, post_seconds(20000, 400, 0.1));
  EXPECT_NEAR(e.estimate_kbps(), 320, 1);
}

// A round trip measured before the first POST (rgbdcast stream: GET /healthz) is the POST model's first fixed cost:
// the first answer then gives the line rate, not a goodput diluted by the round trip. 25 kB in 0.2 s over a
// 2 Mbit/s line with 0.1 s of round trip: 2000 kbit/s with the prior, 1000 without (the goodput).
TEST(LinkEstimator, AMeasuredRoundTripIsTheFirstFixedCost) {
  LinkEstimatorParams with;
  with.initial_fixed_s = 0.1;
  LinkEstimator primed(with), plain(LinkEstimatorParams{});
  EXPECT_DOUBLE_EQ(primed.post_fixed_s(), 0);  // nothing acknowledged yet: the goodput guess, no fixed cost
  primed.on_ack(25000, 0.2);
  plain.on_ack(25000, 0.2);
  EXPECT_NEAR(primed.post_fixed_s(), 0.1, 1e-12);
  EXPECT_NEAR(primed.line_kbps(), 2000, 1e-6);
  EXPECT_NEAR(plain.post_fixed_s(), 0, 1e-12);
  EXPECT_NEAR(plain.line_kbps(), 1000, 1e-6);
  // Once the sizes spread, the fit takes over from the prior (a 100 kB POST at the same line and round trip).
  primed.on_ack(100000, 0.5);
  EXPECT_NEAR(primed.post_fixed_s(), 0.1, 1e-9);
  EXPECT_NEAR(primed.line_kbps(), 2000, 1e-3);
  LinkEstimatorParams bad;
  bad.initial_fixed_s = -1;
  EXPECT_FALSE(bad.validate());
}

TEST(LinkEstimator, EwmaWeightsANewSampleByAlpha) {
  LinkEstimatorParams p;
  p.alpha = 0.25;
  LinkEstimator e(p);
  e.on_ack(100000, 1.0);  // 800 kbit/s: the first sample replaces the guess
  EXPECT_DOUBLE_EQ(e.estimate_kbps(), 800);
  e.on_ack(50000, 1.0);  // 400 kbit/s: below, weighted by alpha_down
  EXPECT_DOUBLE_EQ(e.estimate_kbps(), 0.5 * 400 + 0.5 * 800);
  e.on_ack(200000, 1.0);  // 1600 kbit/s: above, weighted by alpha
  EXPECT_DOUBLE_EQ(e.estimate_kbps(), 0.25 * 1600 + 0.75 * 600);
}

TEST(LinkEstimator, FailuresHalveItDownToTheFloorAndAcksRaiseItAgain) {
  LinkEstimatorParams p;
  p.initial_kbps = 1000;
  LinkEstimator e(p);
  e.on_failure();
  EXPECT_DOUBLE_EQ(e.estimate_kbps(), 500);
  for (int i = 0; i < 20; ++i) e.on_failure();
  EXPECT_DOUBLE_EQ(e.estimate_kbps(), p.floor_kbps);
  for (int i = 0; i < 15; ++i) e.on_ack(30000, post_seconds(30000, 600, 0));
  EXPECT_GT(e.estimate_kbps(), 590);
}

TEST(KeyframeBudget, FollowsAChangedCapDownAndUp) {
  LinkEstimatorParams p;
  p.cap_kbps = 2000;
  LinkEstimator e(p);
  const double interval_s = 0.7;
  // A fast link (10 Mbit/s) acknowledged under a 2 Mbit/s cap: the budget is the realtime ceiling.
  for (int i = 0; i < 5; ++i) e.on_ack(40000, post_seconds(40000, 10000, 0));
  EXPECT_DOUBLE_EQ(keyframe_budget_kb(e.estimate_kbps(), interval_s), 40);
  // --link-kbps 100: 12.5 kB/s x 0.7 s x 0.9 headroom.
  e.set_cap_kbps(100);
  EXPECT_NEAR(keyframe_budget_kb(e.estimate_kbps(), interval_s), 12.5 * 0.7 * 0.9, 1e-9);
  // --link-kbps 300, then no cap: the budget follows back up at once (the average is kept uncapped).
  e.set_cap_kbps(300);
  EXPECT_NEAR(keyframe_budget_kb(e.estimate_kbps(), interval_s), 37.5 * 0.7 * 0.9, 1e-9);
  e.set_cap_kbps(0);
  EXPECT_DOUBLE_EQ(keyframe_budget_kb(e.estimate_kbps(), interval_s), 40);
  // A dead link: the floor.
  for (int i = 0; i < 30; ++i) e.on_failure();
  EXPECT_DOUBLE_EQ(keyframe_budget_kb(e.estimate_kbps(), interval_s), BudgetRule{}.floor_kb);
}

TEST(KeyframeBudget, FollowsALinkThatDegradesAndRecovers) {
  LinkEstimator e(LinkEstimatorParams{});
  KeyframeInterval interval;
  double t = 0, budget = 0;
  auto keyframe = [&](double link_kbps) {
    t += 0.7;
    interval.on_keyframe(t);
    budget = keyframe_budget_kb(e.estimate_kbps(), interval.seconds());
    e.on_ack(static_cast<size_t>(budget * 1000), post_seconds(static_cast<size_t>(budget * 1000), link_kbps, 0.05));
  };
  for (int i = 0; i < 10; ++i) keyframe(2000);
  EXPECT_DOUBLE_EQ(budget, 40);
  for (int i = 0; i < 10; ++i) keyframe(100);
  EXPECT_LT(budget, 9);  // 100 kbit/s carries about 8 kB in 0.7 s
  EXPECT_GT(budget, 4);
  for (int i = 0; i < 10; ++i) keyframe(2000);
  EXPECT_DOUBLE_EQ(budget, 40);
}

TEST(LatencyBudget, KeepsAKeyframeToWhatTheLinkCarriesInTheTargetMinusTheOverhead) {
  LatencyRule latency;  // 1 s
  // 500 kbit/s = 62.5 kB/s; 0.4 s before the POST leaves 0.6 s: 62.5 x 0.6 x 0.9 = 33.75 kB.
  EXPECT_NEAR(latency_budget_kb(500, 0.4, latency), 62.5 * 0.6 * 0.9, 1e-9);
  // The rate rule alone would give the 40 kB ceiling with a keyframe every 2 s; the latency rule is the smaller.
  EXPECT_DOUBLE_EQ(keyframe_budget_kb(500, 2.0), 40);
  EXPECT_NEAR(next_keyframe_budget_kb(500, 2.0, 0.4, latency), 33.75, 1e-9);
  // A short interval makes the rate rule the smaller one: 62.5 x 0.3 x 0.9.
  EXPECT_NEAR(next_keyframe_budget_kb(500, 0.3, 0.4, latency), 62.5 * 0.3 * 0.9, 1e-9);
  // An overhead beyond the target: the POST keeps a quarter of the target, not less.
  EXPECT_NEAR(latency_budget_kb(500, 3.0, latency), 62.5 * 0.25 * 0.9, 1e-9);
  // Fast links reach the ceiling, dead ones the floor; target 0 turns the rule off.
  EXPECT_DOUBLE_EQ(latency_budget_kb(10000, 0.4, latency), 40);
  EXPECT_DOUBLE_EQ(latency_budget_kb(8, 0.4, latency), BudgetRule{}.floor_kb);
  EXPECT_DOUBLE_EQ(latency_budget_kb(500, 0.4, LatencyRule{0.0, 0.25}), 40);
}

TEST(LatencyBudget, ConvergesToPostsThatTakeTheirShareOnALinkWithAFixedCostPerPost) {
  // A 500 kbit/s line with 0.15 s per POST for the round trip and the server: the goodput estimate of a budget-sized
  // POST feeds the next budget. The fixed point is a POST of (target - overhead) x headroom seconds.
  LinkEstimatorParams p;
  p.cap_kbps = 500;
  LinkEstimator e(p);
  LatencyRule latency;
  const double overhead_s = 0.3, fixed_s = 0.15;
  double budget = 0, post_s = 0;
  for (int i = 0; i < 40; ++i) {
    budget = next_keyframe_budget_kb(e.estimate_kbps(), 5.0, overhead_s, latency);
    post_s = post_seconds(static_cast<size_t>(budget * 1000), 500, fixed_s);
    e.on_ack(static_cast<size_t>(budget * 1000), post_s);
  }
  EXPECT_NEAR(post_s, (1.0 - overhead_s) * 0.9, 0.01);
  EXPECT_LE(overhead_s + post_s, 1.0);
  EXPECT_NEAR(budget, 62.5 * ((1.0 - overhead_s) * 0.9 - fixed_s), 0.5);
}

// The POST model: a 500 kbit/s line with 0.15 s per POST (round trip + server). POSTs of two sizes separate the two
// terms; POSTs of one size cannot, and keep the last good fixed cost.
TEST(PostCostModel, FitsTheFixedCostAndTheLineRateFromPostsOfSeveralSizes) {
  PostCostModel m;
  EXPECT_TRUE(m.empty());
  m.on_sample(20000, post_seconds(20000, 500, 0.15));
  EXPECT_FALSE(m.fitted());  // one size: no fit yet, the goodput stands in
  EXPECT_DOUBLE_EQ(m.fixed_s(), 0);
  EXPECT_NEAR(m.rate_bytes_per_s(), 20000 / 0.47, 1);
  for (size_t bytes : {8000u, 30000u, 15000u, 40000u}) m.on_sample(bytes, post_seconds(bytes, 500, 0.15));
  EXPECT_TRUE(m.fitted());
  EXPECT_NEAR(m.fixed_s(), 0.15, 1e-6);
  EXPECT_NEAR(m.rate_bytes_per_s() * 8 / 1000, 500, 1e-3);
  // The link slows to 250 kbit/s: the model follows within a few POSTs (older samples are forgotten).
  for (int i = 0; i < 12; ++i)
    for (size_t bytes : {10000u, 30000u}) m.on_sample(bytes, post_seconds(bytes, 250, 0.15));
  EXPECT_NEAR(m.rate_bytes_per_s() * 8 / 1000, 250, 5);
  EXPECT_NEAR(m.fixed_s(), 0.15, 0.02);
  // Then the line speeds up to 400 kbit/s while the POSTs are of one size: they cannot tell the two terms apart, so
  // the fits made while the old sizes fade give some of the change to the fixed cost; once the sizes no longer
  // spread, the fixed cost is kept and the rate is what is left. What holds: the model predicts the POSTs it sees,
  // and never a fixed cost above the true one (it errs toward the goodput rule, the conservative side).
  for (int i = 0; i < 30; ++i) m.on_sample(20000, post_seconds(20000, 400, 0.15));
  EXPECT_FALSE(m.fitted());
  EXPECT_LE(m.fixed_s(), 0.15 + 1e-9);
  EXPECT_NEAR(m.fixed_s() + 20000 / m.rate_bytes_per_s(), post_seconds(20000, 400, 0.15), 0.01);
}

TEST(LinkEstimator, ReportsTheLineRateUnderTheCapAndFailuresLowerIt) {
  LinkEstimatorParams p;
  p.cap_kbps = 500;
  LinkEstimator e(p);
  EXPECT_DOUBLE_EQ(e.line_kbps(), 500);  // before any POST: the goodput guess (capped)
  EXPECT_DOUBLE_EQ(e.post_fixed_s(), 0);
  for (int i = 0; i < 4; ++i)
    for (size_t bytes : {10000u, 30000u}) e.on_ack(bytes, post_seconds(bytes, 500, 0.15));
  EXPECT_NEAR(e.line_kbps(), 500, 1);  // the line, not the goodput of these POSTs ...
  EXPECT_LT(e.estimate_kbps(), 400);   // ... which the round trip dilutes
  EXPECT_NEAR(e.post_fixed_s(), 0.15, 1e-3);
  e.on_failure();
  EXPECT_NEAR(e.line_kbps(), 250, 1);
  e.on_ack(20000, post_seconds(20000, 500, 0.15));
  EXPECT_NEAR(e.line_kbps(), 500, 2);
  e.set_cap_kbps(100);
  EXPECT_DOUBLE_EQ(e.line_kbps(), 100);
}

// With the POST model the budgets use the line rate less the fixed cost: from the first keyframe, the POST takes
// the time it was given (the goodput rule reaches that only after several POSTs), and the refinement budget is what
// an idle window carries.
TEST(KeyframeBudget, TheFixedCostPerPostComesOffTheWindowOnce) {
  const double fixed_s = 0.15;
  // Rate rule: 62.5 kB/s x (0.7 s x 0.9 - 0.15 s).
  EXPECT_NEAR(keyframe_budget_kb(500, 0.7, BudgetRule{}, fixed_s), 62.5 * (0.7 * 0.9 - 0.15), 1e-9);
  // Latency rule: 0.3 s before the POST leaves 0.7 s; 62.5 x (0.7 x 0.9 - 0.15) = 30 kB, whose POST then takes
  // 0.15 + 30 / 62.5 = 0.63 s = 0.7 x 0.9.
  const double kb = latency_budget_kb(500, 0.3, LatencyRule{}, BudgetRule{}, fixed_s);
  EXPECT_NEAR(kb, 30, 1e-9);
  EXPECT_NEAR(fixed_s + kb / 62.5, 0.7 * 0.9, 1e-9);
  // Refinements: 2 Mbit/s for 1 s: 250 x (0.9 - 0.15) = 187.5 kB, held to the ceiling; 100 kbit/s: 9.4 kB; a
  // window shorter than the fixed cost buys nothing.
  EXPECT_DOUBLE_EQ(refinement_budget_kb(2000, 1.0, fixed_s, 100), 100);
  EXPECT_NEAR(refinement_budget_kb(100, 1.0, fixed_s, 100), 12.5 * 0.75, 1e-9);
  EXPECT_DOUBLE_EQ(refinement_budget_kb(2000, 0.1, fixed_s, 100), 0);
}

TEST(SmoothedDuration, IsTheMeanPlusTwoDeviationsAndStaysHighAfterASpike) {
  SmoothedDuration d(0.15);
  EXPECT_DOUBLE_EQ(d.value(), 0.15);  // before the first sample
  d.on_sample(0.2);                   // mean 0.2, deviation 0.1
  EXPECT_NEAR(d.value(), 0.2 + 2 * 0.1, 1e-12);
  for (int i = 0; i < 60; ++i) d.on_sample(0.2);  // steady: the deviation decays towards 0
  EXPECT_NEAR(d.value(), 0.2, 0.01);
  d.on_sample(0.6);  // one slow reduction: the deviation jumps by a quarter of the miss, the mean by an eighth
  EXPECT_NEAR(d.value(), (0.875 * 0.2 + 0.125 * 0.6) + 2 * 0.25 * 0.4, 0.01);
  EXPECT_GT(d.value(), 0.4);
}

TEST(CapFile, ReportsANewValueOnlyWhenTheTextChangesAndRefusesGarbage) {
  const std::string dir = rgbdcast::test::temp_dir("cap_file");
  const std::string path = dir + "/link_kbps";
  auto write = [&](const std::string& text) { std::ofstream(path, std::ios::trunc) << text; };
  CapFile f(path);
  auto missing = f.poll();
  ASSERT_TRUE(missing);
  EXPECT_FALSE(*missing);  // not there yet: nothing to change
  write("500\n");
  auto v = f.poll();
  ASSERT_TRUE(v);
  ASSERT_TRUE(*v);
  EXPECT_DOUBLE_EQ(**v, 500);
  auto same = f.poll();
  ASSERT_TRUE(same);
  EXPECT_FALSE(*same);
  write("100");
  v = f.poll();
  ASSERT_TRUE(v && *v);
  EXPECT_DOUBLE_EQ(**v, 100);
  for (const char* bad : {"fast", "-5", "100 200", "nan", ""}) {
    write(bad);
    EXPECT_FALSE(f.poll()) << "'" << bad << "'";
  }
  write("0");  // no cap
  v = f.poll();
  ASSERT_TRUE(v && *v);
  EXPECT_DOUBLE_EQ(**v, 0);
  rgbdcast::test::remove_tree_quietly(dir);
}

TEST(KeyframeInterval, SmoothsAndClampsTheGaps) {
  KeyframeInterval k(1.0, 0.5, 0.25, 5.0);
  EXPECT_DOUBLE_EQ(k.seconds(), 1.0);
  k.on_keyframe(10.0);
  EXPECT_DOUBLE_EQ(k.seconds(), 1.0);  // one keyframe: no gap yet
  k.on_keyframe(10.6);
  EXPECT_NEAR(k.seconds(), 0.6, 1e-12);
  k.on_keyframe(100.0);  // a stall counts as max_s
  EXPECT_NEAR(k.seconds(), 0.5 * 5.0 + 0.5 * 0.6, 1e-12);
}

TEST(Backoff, GrowsExponentiallyWithJitterUpToTheCap) {
  BackoffParams p;  // 0.2 s x 2^n, cap 2 s, jitter 50 %
  Backoff b(p);
  std::mt19937 rng(7);
  const double expected[] = {0.2, 0.4, 0.8, 1.6, 2.0, 2.0, 2.0};
  for (double d : expected) {
    const double got = b.next_delay_s(rng);
    EXPECT_GE(got, 0.5 * d - 1e-12);
    EXPECT_LE(got, d + 1e-12);
  }
  EXPECT_EQ(b.failures(), 7);
  b.reset();
  EXPECT_LE(b.next_delay_s(rng), 0.2);
}

TEST(Backoff, JitterSpreadsSendersThatFailedTogether) {
  Backoff a(BackoffParams{}), b(BackoffParams{});
  std::mt19937 ra(1), rb(2);
  int differ = 0;
  for (int i = 0; i < 6; ++i) differ += a.next_delay_s(ra) != b.next_delay_s(rb);
  EXPECT_EQ(differ, 6);
}

TEST(Backoff, HonoursRetryAfterUpToItsLimit) {
  Backoff b(BackoffParams{});
  std::mt19937 rng(3);
  EXPECT_DOUBLE_EQ(b.next_delay_s(rng, 5.0), 5.0);
  EXPECT_DOUBLE_EQ(b.next_delay_s(rng, 1000.0), BackoffParams{}.retry_after_max_s);
}

TEST(Backoff, BadParametersAreRefused) {
  BackoffParams p;
  p.initial_s = 0;
  EXPECT_FALSE(p.validate());
  LinkEstimatorParams l;
  l.cap_kbps = -1;
  EXPECT_FALSE(l.validate());
}

}  // namespace
}  // namespace rgbdcast::stream
