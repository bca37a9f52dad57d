// The sender through an outage (stream/sender.h): the server is down, then answers 503 with Retry-After, then
// swallows one answer (the client gives up after the keyframe was stored). Every keyframe ends up stored exactly
// once, newest first, the re-post of the stored one is answered 200, and the retries backed off. The server is the
// tests' mission server on the service's MissionStore (fake_mission_server.h), scripted; the real service is
// exercised end to end in test_stream_cli.cpp. What the tests assert is order and counts (what reached the server
// before which answer), and lower bounds that the sender's own waits guarantee (pacing at the cap, backoff), never
// an upper bound on wall-clock time: a server holds an answer until the event the case is about has happened.
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "stream/clock.h"
#include "stream/sender.h"
#include "tests/common/test_data.h"
#include "tests/stream/fake_mission_server.h"

namespace rgbdcast::stream {
namespace {

// A port nothing listens on: bound to port 0, read back, closed.
int free_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof addr;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0) {
    ::close(fd);
    return -1;
  }
  ::close(fd);
  return ntohs(addr.sin_port);
}

// `lanes` uplinks to one server, for a Sender with that many POSTs in flight.
struct Lanes {
  std::vector<std::unique_ptr<Uplink>> owned;
  std::vector<Uplink*> uplinks;
};
Lanes make_lanes(int port, size_t lanes) {
  Lanes out;
  UplinkOptions uo;
  uo.server_url = "http://127.0.0.1:" + std::to_string(port);
  for (size_t i = 0; i < lanes; ++i) {
    auto uplink = Uplink::create(uo);
    EXPECT_TRUE(uplink);
    if (!uplink) continue;
    out.owned.push_back(std::move(*uplink));
    out.uplinks.push_back(out.owned.back().get());
  }
  return out;
}

using rgbdcast::test::FakeMissionServer;
using rgbdcast::test::ServedPost;

// Waits at most 30 s until nothing is pending (a sender that never gets there fails the test's counts).
void wait_until_delivered(const Sender& sender) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (sender.stats().pending > 0 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
}

// The most POSTs the server held at once: bodies read and not yet answered.
int most_at_once(const std::vector<ServedPost>& posts) {
  int most = 0;
  for (const ServedPost& p : posts) {
    int at_once = 0;
    for (const ServedPost& q : posts)
      if (q.body_step <= p.body_step && (q.answer_step < 0 || q.answer_step > p.body_step)) ++at_once;
    most = std::max(most, at_once);
  }
  return most;
}

// Closes the lanes' connections: a server stops at once then, instead of waiting for its keep-alive connections to
// time out (5 s).
void close_lanes(Lanes& lanes) {
  lanes.uplinks.clear();
  lanes.owned.clear();
}

// lanes: POSTs in flight at once (one uplink each).
void outage_run(size_t lanes) {
  const std::string dir = test::temp_dir("sender_outage");
  auto box = Outbox::open(dir, "outage");
  ASSERT_TRUE(box);
  for (int i = 0; i < 3; ++i) {
    OutboxEntry e;
    e.frame_index = 10 * i;
    e.pose = {0.1 * i, 0, 0, 0, 0, 0, 1};
    ASSERT_TRUE((*box)->add(e, std::vector<std::uint8_t>(3000 + i, static_cast<std::uint8_t>(i))));
  }
  const int port = free_port();
  ASSERT_GT(port, 0);
  Lanes lane_uplinks = make_lanes(port, lanes);
  ASSERT_EQ(lane_uplinks.uplinks.size(), lanes);
  SenderParams sp;
  sp.mission = "outage";
  sp.seed = 11;
  Sender sender(**box, lane_uplinks.uplinks, sp);
  sender.start();

  // Down: connections refused until the sender has failed three times.
  SenderStats down = sender.stats();
  const auto down_deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (down.failures < 3 && std::chrono::steady_clock::now() < down_deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    down = sender.stats();
  }
  EXPECT_EQ(down.lanes, lanes);
  EXPECT_GE(down.failures, 3u);
  EXPECT_TRUE(down.link_down);
  EXPECT_LT(down.estimate_kbps, 500.0);  // failures lowered the estimate
  EXPECT_EQ(down.pending, 3u);
  // Backed off, not a busy loop (the lanes share one backoff): after a failure, no new attempt starts before the
  // shortest delay (half of 0.2 s with the jitter); only those another lane had already picked (lanes - 1 at most).
  const std::vector<PostRecord> failed = sender.post_log();
  ASSERT_GE(failed.size(), 3u);
  for (const PostRecord& f : failed) {
    size_t right_after = 0;
    for (const PostRecord& g : failed) right_after += g.started > f.ended && g.started - f.ended < 0.09;
    EXPECT_LE(right_after, lanes - 1) << "attempts right after a failure";
  }

  FakeMissionServer::Script script;
  script.fail_with_503 = 2;  // then the first stored keyframe's answer is lost
  script.swallow = 1;
  FakeMissionServer server(script);
  ASSERT_EQ(server.start(port), port);
  wait_until_delivered(sender);
  sender.stop();
  close_lanes(lane_uplinks);
  server.stop();  // every answer sent, the swallowed one too

  const SenderStats done = sender.stats();
  EXPECT_EQ(done.pending, 0u);
  EXPECT_EQ(done.acked, 3u);
  EXPECT_EQ(done.rejected, 0u);
  EXPECT_EQ(server.held_too_long(), 0);
  std::vector<int> created_order;
  int answered_200 = 0, answered_503 = 0;
  for (const ServedPost& p : server.posts()) {
    if (p.status == 201) created_order.push_back(p.seq);
    answered_200 += p.status == 200;
    answered_503 += p.status == 503;
  }
  EXPECT_EQ(answered_503, 2);
  EXPECT_EQ(answered_200, 1);  // the keyframe whose answer was lost, re-posted identically
  ASSERT_EQ(created_order.size(), 3u);
  if (lanes == 1) {
    EXPECT_EQ(created_order.front(), 2);  // newest first
  } else {
    // Newest first, two at a time: the two newest are stored before the oldest (their order is the network's).
    EXPECT_EQ(created_order.back() == 0 || created_order[1] == 0, true);
    EXPECT_NE(created_order.front(), 0);
  }
  const auto stored = server.keyframes("outage");
  ASSERT_EQ(stored.size(), 3u);
  for (int seq = 0; seq < 3; ++seq) {
    EXPECT_EQ(stored[static_cast<size_t>(seq)].seq, seq);
    EXPECT_EQ(stored[static_cast<size_t>(seq)].bytes, static_cast<std::uint64_t>(3000 + seq));
    EXPECT_TRUE((*box)->entry(seq)->acked);
  }
  test::remove_tree_quietly(dir);
}

TEST(SenderOutage, EveryKeyframeIsStoredExactlyOnceAfterTheLinkReturns) { outage_run(1); }

TEST(SenderOutage, EveryKeyframeIsStoredExactlyOnceWithTwoPostsInFlight) { outage_run(2); }

// Six keyframes of 10 kB at a cap of 800 kbit/s (0.1 s each at the cap). With two lanes the server answers a POST
// only once another POST's body has come (or all six have): the sender must start the second POST while the
// first one's answer is outstanding, or the hold gives up and the test fails. With one lane it answers at once and
// never holds two. Either way the bodies are paced back to back at the cap (the sender's own log: a POST starts no
// earlier than the bodies before it take at the cap), never more POSTs are out than lanes, and all six are stored
// exactly once.
TEST(SenderLanes, TwoPostsInFlightArePacedAtTheCapAndStoredExactlyOnce) {
  struct Run {
    SenderStats stats;
    std::vector<PostRecord> log;
    std::vector<ServedPost> posts;
    size_t stored = 0;
    int held_too_long = 0;
  };
  auto run = [](size_t lanes) {
    Run out;
    const std::string dir = test::temp_dir("sender_lanes");
    auto box = Outbox::open(dir, "lanes");
    EXPECT_TRUE(box);
    for (int i = 0; i < 6; ++i) {
      OutboxEntry e;
      e.frame_index = i;
      e.pose = {0.1 * i, 0, 0, 0, 0, 0, 1};
      EXPECT_TRUE((*box)->add(e, std::vector<std::uint8_t>(10000, static_cast<std::uint8_t>(i))));
    }
    FakeMissionServer::Script script;
    if (lanes > 1)
      script.hold = [](FakeMissionServer& server, const ServedPost& post) {
        server.wait_until([&](const std::vector<ServedPost>& posts) {
          if (posts.size() >= 6) return true;
          for (const ServedPost& p : posts)
            if (p.body_step > post.body_step) return true;
          return false;
        });
      };
    FakeMissionServer server(script);
    const int port = server.start();
    EXPECT_GT(port, 0);
    Lanes lane_uplinks = make_lanes(port, lanes);
    SenderParams sp;
    sp.mission = "lanes";
    sp.link.cap_kbps = 800;  // 10 kB: 0.1 s at the cap
    Sender sender(**box, lane_uplinks.uplinks, sp);
    sender.start();
    wait_until_delivered(sender);
    sender.stop();
    out.stats = sender.stats();
    out.log = sender.post_log();
    out.posts = server.posts();
    out.stored = server.keyframes("lanes").size();
    out.held_too_long = server.held_too_long();
    close_lanes(lane_uplinks);
    server.stop();
    test::remove_tree_quietly(dir);
    return out;
  };
  const Run one = run(1), two = run(2);
  for (const Run* r : {&one, &two}) {
    EXPECT_EQ(r->stats.acked, 6u);
    EXPECT_EQ(r->stats.pending, 0u);
    EXPECT_EQ(r->held_too_long, 0);
    EXPECT_EQ(r->stored, 6u);
    ASSERT_EQ(r->posts.size(), 6u);  // no re-post was needed
    for (const ServedPost& p : r->posts) EXPECT_EQ(p.status, 201) << "seq " << p.seq;
    // Paced at the cap: each POST started at least its predecessor's body time at the cap after it (the log's
    // times are taken just after the sender's wait, so half of it is held to, as a margin for that step).
    std::vector<PostRecord> log = r->log;
    ASSERT_EQ(log.size(), 6u);
    std::sort(log.begin(), log.end(), [](const PostRecord& a, const PostRecord& b) { return a.started < b.started; });
    for (size_t i = 1; i < log.size(); ++i) {
      const double body_s = static_cast<double>(log[i - 1].bytes) * 8.0 / 800e3;
      EXPECT_GE(log[i].started - log[i - 1].started, 0.5 * body_s) << i;
    }
    EXPECT_GE(log.back().started - log.front().started, 0.9 * 5 * 10000 * 8.0 / 800e3);
  }
  EXPECT_EQ(most_at_once(one.posts), 1);
  EXPECT_EQ(most_at_once(two.posts), 2);
  // Every POST but the last was still unanswered when the next body came: the line did not wait for answers.
  for (size_t i = 0; i + 1 < two.posts.size(); ++i) EXPECT_GT(two.posts[i].answer_step, two.posts[i + 1].body_step);
  EXPECT_EQ(one.stats.overlap_s, 0.0);
  EXPECT_GT(two.stats.overlap_s, 0.0);
  EXPECT_GT(two.stats.busy_s, two.stats.overlap_s);
}

// The setup of the tests on the injected clock: an outbox in a temporary folder, a manual clock, the sender's
// parameters on it, and the lanes (made by the test, closed before its server stops).
struct OnManualClock {
  explicit OnManualClock(const std::string& mission) : dir(test::temp_dir("sender_" + mission)) {
    auto opened = Outbox::open(dir, mission);
    EXPECT_TRUE(opened);
    if (opened) box = std::move(*opened);
    params.mission = mission;
    params.clock = &clock;
  }
  ~OnManualClock() {
    close_lanes(lanes);
    test::remove_tree_quietly(dir);
  }
  std::string dir;
  std::unique_ptr<Outbox> box;
  ManualClock clock;
  SenderParams params;
  Lanes lanes;
};

// On a manual clock (stream/clock.h) the pacing at the cap is a deadline on that clock: three keyframes of 10 kB
// at 800 kbit/s (0.1 s each); each POST after the first starts only when the clock reaches the time the bodies
// before it take at the cap, and the lane sleeps on the clock until then (no POST meanwhile). What the link owes
// drains with that clock.
TEST(SenderLanes, PacingAtTheCapWaitsOnTheInjectedClock) {
  OnManualClock t("clocked");
  ASSERT_TRUE(t.box);
  for (int i = 0; i < 3; ++i) {
    OutboxEntry e;
    e.frame_index = i;
    e.captured = 100.0 + i;
    ASSERT_TRUE(t.box->add(e, std::vector<std::uint8_t>(10000, static_cast<std::uint8_t>(i))));
  }
  FakeMissionServer server;
  const int port = server.start();
  ASSERT_GT(port, 0);
  t.lanes = make_lanes(port, 1);
  const Clock::time_point t0 = t.clock.now();
  t.params.link.cap_kbps = 800;
  {
    Sender sender(*t.box, t.lanes.uplinks, t.params);
    sender.start();
    for (size_t posted = 1; posted < 3; ++posted) {
      const Clock::time_point next = t.clock.next_deadline();
      EXPECT_EQ(next, t0 + std::chrono::milliseconds(100) * posted);
      EXPECT_EQ(server.posts().size(), posted);  // the next one waits for the clock
      if (posted == 1) {
        // What the link owes: 0.1 s left on the paced line, and the pending bytes at the estimate, which the clock
        // alone does not bring down (owed_falls_to).
        const double bytes_s = sender.owed_s() - 0.1;
        EXPECT_EQ(sender.owed_falls_to(bytes_s + 0.2), t.clock.now());
        EXPECT_EQ(sender.owed_falls_to(bytes_s - 0.01), Clock::kNever);
        const std::chrono::duration<double> at = sender.owed_falls_to(bytes_s + 0.04) - t0;
        EXPECT_NEAR(at.count(), 0.06, 1e-6);
      }
      t.clock.set(next);
    }
    wait_until_delivered(sender);
    sender.stop();  // the lane has logged its last POST (the outbox says acknowledged before)
    EXPECT_EQ(server.posts().size(), 3u);
    EXPECT_EQ(t.clock.now(), t0 + std::chrono::milliseconds(200));
    const std::vector<PostRecord> log = sender.post_log();
    ASSERT_EQ(log.size(), 3u);
    EXPECT_GT(log[0].seq, log[1].seq);  // newest first
    EXPECT_GT(log[1].seq, log[2].seq);
  }
  close_lanes(t.lanes);
  server.stop();
}

// A keyframe's wait in the outbox (Sender::queue_wait_s, which the latency rule subtracts) is measured on the injected
// wall clock, the one the producer stamps `reduced` with: three keyframes of 10 kB reduced at once and paced at
// 800 kbit/s start their POSTs 0, 0.1 and 0.2 s later, so the smoothed wait is 0.3 x 0.2 + 0.7 x (0.3 x 0.1) s
// exactly; each POST's start is recorded in the outbox and the post log on that clock.
TEST(SenderLanes, TheOutboxWaitIsMeasuredOnTheInjectedWallClock) {
  OnManualClock t("queue_wait");
  ASSERT_TRUE(t.box);
  const double unix_at_start = 1.7e9;
  const double clock_at_start = t.clock.now_s();
  t.params.unix_s = [&t, unix_at_start, clock_at_start] { return unix_at_start + (t.clock.now_s() - clock_at_start); };
  for (int i = 0; i < 3; ++i) {
    OutboxEntry e;
    e.frame_index = i;
    e.captured = unix_at_start - 1.0 + 0.1 * i;
    e.reduced = unix_at_start;
    ASSERT_TRUE(t.box->add(e, std::vector<std::uint8_t>(10000, static_cast<std::uint8_t>(i))));
  }
  FakeMissionServer server;
  const int port = server.start();
  ASSERT_GT(port, 0);
  t.lanes = make_lanes(port, 1);
  t.params.link.cap_kbps = 800;
  std::vector<PostRecord> log;
  {
    Sender sender(*t.box, t.lanes.uplinks, t.params);
    EXPECT_EQ(sender.queue_wait_s(), 0.0);  // none yet
    sender.start();
    for (size_t posted = 1; posted < 3; ++posted) t.clock.set(t.clock.next_deadline());
    wait_until_delivered(sender);
    sender.stop();
    EXPECT_NEAR(sender.queue_wait_s(), 0.3 * 0.2 + 0.7 * (0.3 * 0.1 + 0.7 * 0.0), 1e-5);
    log = sender.post_log();
  }
  ASSERT_EQ(log.size(), 3u);
  for (size_t i = 0; i < log.size(); ++i) {
    EXPECT_NEAR(log[i].started, unix_at_start + 0.1 * static_cast<double>(i), 1e-5) << i;
    EXPECT_NEAR(log[i].ended, log[i].started, 1e-6) << i;  // the clock does not move while a POST is answered
    const auto entry = t.box->entry(log[i].seq);
    ASSERT_TRUE(entry);
    EXPECT_NEAR(entry->post_started, log[i].started, 1e-6) << i;
  }
  close_lanes(t.lanes);
  server.stop();
}

// A refused POST is retried after the backoff's delay on the injected clock (0.1-0.2 s for the first failure, a
// longer one after the second), not before the clock reaches it.
TEST(SenderOutage, ARetryWaitsForTheBackoffOnTheInjectedClock) {
  OnManualClock t("backoff");
  ASSERT_TRUE(t.box);
  ASSERT_TRUE(t.box->add(OutboxEntry{}, std::vector<std::uint8_t>(100, 1)));
  const int port = free_port();
  ASSERT_GT(port, 0);
  t.lanes = make_lanes(port, 1);
  const Clock::time_point t0 = t.clock.now();
  t.params.seed = 5;
  Sender sender(*t.box, t.lanes.uplinks, t.params);
  sender.start();
  const Clock::time_point first = t.clock.next_deadline();
  EXPECT_GE(first - t0, std::chrono::milliseconds(100));
  EXPECT_LE(first - t0, std::chrono::milliseconds(200));
  EXPECT_EQ(sender.stats().failures, 1u);
  t.clock.set(first);
  const Clock::time_point second = t.clock.next_deadline();
  EXPECT_EQ(sender.stats().failures, 2u);
  EXPECT_GE(second - first, std::chrono::milliseconds(200));  // 0.4 s x [0.5, 1]
  EXPECT_TRUE(sender.stats().link_down);
  sender.stop();
}

// A lane with nothing to post waits for the outbox to change, not on a period: an entry added after start goes
// once notify() is called, on a clock that never moves.
TEST(Sender, AnEntryAddedAfterStartIsPostedOnNotify) {
  OnManualClock t("notify");
  ASSERT_TRUE(t.box);
  FakeMissionServer server;
  const int port = server.start();
  ASSERT_GT(port, 0);
  t.lanes = make_lanes(port, 1);
  {
    Sender sender(*t.box, t.lanes.uplinks, t.params);
    sender.start();
    ASSERT_TRUE(t.box->add(OutboxEntry{}, std::vector<std::uint8_t>(100, 1)));
    sender.notify();
    wait_until_delivered(sender);
    EXPECT_EQ(sender.stats().acked, 1u);
  }
  EXPECT_EQ(server.keyframes("notify").size(), 1u);
  close_lanes(t.lanes);
  server.stop();
}

TEST(SenderOutage, ARefusedTokenStopsTheSender) {
  const std::string dir = test::temp_dir("sender_token");
  auto box = Outbox::open(dir, "auth");
  ASSERT_TRUE(box);
  ASSERT_TRUE((*box)->add(OutboxEntry{}, std::vector<std::uint8_t>(100, 1)));
  FakeMissionServer::Script script;
  script.refuse_token = true;
  FakeMissionServer server(script);
  const int port = server.start();
  ASSERT_GT(port, 0);
  UplinkOptions uo;
  uo.server_url = server.url();
  uo.token = "wrong-token-wrong-token";
  auto uplink = Uplink::create(uo);
  ASSERT_TRUE(uplink);
  SenderParams sp;
  sp.mission = "auth";
  Sender sender(**box, **uplink, sp);
  sender.start();
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (sender.stats().fatal.empty() && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  const SenderStats s = sender.stats();
  EXPECT_NE(s.fatal.find("HTTP 401"), std::string::npos) << s.fatal;
  EXPECT_EQ(s.pending, 1u);  // kept in the outbox for a run with the right token
  sender.stop();
  EXPECT_EQ(server.posts().size(), 1u);  // not retried
  EXPECT_TRUE(server.keyframes("auth").empty());
  test::remove_tree_quietly(dir);
}

TEST(Sender, TheWaitForAnAnswerIsThreeSecondsPlusFourTransfersAtAnEstimateOfAtLeast64Kbps) {
  struct Case {
    size_t bytes;
    double estimate_kbps, timeout_s;
  };
  const std::vector<Case> cases = {
      {0, 1000, 3.0},  {125000, 1000, 7.0},     // 1 s at 1 Mbit/s: 3 + 4
      {8000, 10, 7.0},                          // an estimate that failures pushed to 10 kbit/s counts as 64: 1 s
      {8000, 64, 7.0}, {10000000, 1000, 60.0},  // 80 s of transfer: at most 60
  };
  for (const Case& c : cases)
    EXPECT_NEAR(answer_timeout_s(c.bytes, c.estimate_kbps), c.timeout_s, 1e-9) << c.bytes << " " << c.estimate_kbps;
}

TEST(Sender, AConflictIsOursWhenTheMissionStoresThisRevisionWithTheseBytesOrANewerOne) {
  const std::string mission = R"({"keyframes":[{"seq":3,"rev":1,"bytes":5000},{"seq":4,"rev":0,"bytes":7000}]})";
  struct Case {
    std::string name, json;
    int seq, rev;
    size_t bytes;
    bool ours;
  };
  const std::vector<Case> cases = {
      {"same revision and bytes", mission, 4, 0, 7000, true},
      {"same revision, other bytes", mission, 4, 0, 6999, false},
      {"a newer revision is stored", mission, 3, 0, 1, true},
      {"an older revision is stored", mission, 3, 2, 5000, false},
      {"another seq", mission, 5, 0, 7000, false},
      {"no keyframes", R"({"id":"m"})", 4, 0, 7000, false},
      {"not JSON", "<html>", 4, 0, 7000, false},
  };
  for (const Case& c : cases) {
    const auto stored = stored_keyframe(c.json, c.seq, c.rev, c.bytes);
    EXPECT_EQ(stored.has_value(), c.ours) << c.name;
    if (stored) {
      EXPECT_NE(stored->find("\"seq\":" + std::to_string(c.seq)), std::string::npos) << c.name;
    }
  }
}

TEST(Uplink, BadUrlsAndTokenFilesGetOneLineErrors) {
  for (const char* url : {"localhost:8080", "ftp://host", "http://host/path", "http://", ""}) {
    UplinkOptions uo;
    uo.server_url = url;
    auto u = Uplink::create(uo);
    EXPECT_FALSE(u) << url;
    if (!u) {
      EXPECT_EQ(u.error().message.find('\n'), std::string::npos);
    }
  }
  const std::string dir = test::temp_dir("token_files");
  EXPECT_EQ(read_token_file(dir + "/missing").error().code, ErrorCode::kNotFound);
  std::ofstream(dir + "/empty") << "  \n";
  EXPECT_EQ(read_token_file(dir + "/empty").error().code, ErrorCode::kInvalidInput);
  std::ofstream(dir + "/two") << "abc def\n";
  EXPECT_EQ(read_token_file(dir + "/two").error().code, ErrorCode::kInvalidInput);
  std::ofstream(dir + "/good") << "  s3cret-token-0123456789\n";
  EXPECT_EQ(*read_token_file(dir + "/good"), "s3cret-token-0123456789");
  test::remove_tree_quietly(dir);
}

}  // namespace
}  // namespace rgbdcast::stream

namespace rgbdcast::stream {
namespace {

// Bodies of real bytes (a TUM colour PNG), cut to the sizes a test needs: the sender does not look inside.
std::vector<std::uint8_t> real_bytes(size_t n, size_t from) {
  std::ifstream in(test::data_path("tum/rgbd_dataset_freiburg1_xyz_200_319/rgb/1305031108.843264.png"),
                   std::ios::binary);
  std::vector<std::uint8_t> all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_GE(all.size(), from + n);
  return std::vector<std::uint8_t>(all.begin() + static_cast<long>(std::min(from, all.size())),
                                   all.begin() + static_cast<long>(std::min(from + n, all.size())));
}

// Starts `server` and a sender with three lanes to it (two for keyframes, as rgbdcast stream gives refinements one
// more) at a cap of 800 kbit/s (100 kB/s: 0.1 s per 10 kB).
std::unique_ptr<Sender> start_three_lanes(test::FakeMissionServer& server, Lanes& lanes, Outbox& box,
                                          const std::string& mission) {
  const int port = server.start();
  EXPECT_GT(port, 0);
  lanes = make_lanes(port, 3);
  SenderParams sp;
  sp.mission = mission;
  sp.link.cap_kbps = 800;
  sp.max_first_in_flight = 2;
  auto sender = std::make_unique<Sender>(box, lanes.uplinks, sp);
  sender->start();
  return sender;
}

const test::ServedPost* find_post(const std::vector<test::ServedPost>& posts, int seq, int rev) {
  for (const test::ServedPost& p : posts)
    if (p.seq == seq && p.rev == rev) return &p;
  ADD_FAILURE() << "seq " << seq << " rev " << rev << " never arrived";
  return nullptr;
}

}  // namespace

// Three lanes (two for keyframes, as rgbdcast stream gives refinements one more), a cap of 800 kbit/s (100 kB/s) and
// a server that answers keyframe B only once the refinement's body has come. Pending at the start: keyframe B's
// first revision (20 kB) and a refinement of keyframe A (rev 1, 60 kB). B goes first; the refinement starts once B's
// body is on the line, before B's answer (the line carries it while that answer is awaited: else the hold gives up
// and the test fails); keyframe C (10 kB), added once the refinement's POST has started (its body takes 0.6 s at the
// cap), goes ahead of the rest of it (its body reaches the server first), and the refinement's body still takes its
// bytes and C's at the cap (the cap holds). Everything is stored once.
TEST(SenderLanes, ARefinementFillsTheWaitForAnAnswerAndANewKeyframeOvertakesIt) {
  REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz_200_319/rgb/1305031108.843264.png");
  const std::string dir = test::temp_dir("sender_refine_lane");
  auto box = Outbox::open(dir, "refine");
  ASSERT_TRUE(box);
  const double unix_now = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  auto make = [&](int frame, double reduced) {
    OutboxEntry e;
    e.frame_index = frame;
    e.captured = 1000 + frame;
    e.reduced = reduced;
    e.pose = {0.1 * frame, 0, 0, 0, 0, 0, 1};
    return e;
  };
  // A: reduced a minute ago, acknowledged, now refined (a refinement keeps its keyframe's times).
  auto a = (*box)->add(make(0, unix_now - 60), real_bytes(8000, 0));
  ASSERT_TRUE(a);
  ASSERT_TRUE((*box)->mark_attempted(a->seq, 1));
  ASSERT_TRUE((*box)->mark_acked(a->seq, R"({"seq":0})"));
  ASSERT_TRUE((*box)->revise(a->seq, real_bytes(60000, 8000), 60, 1000));
  auto b = (*box)->add(make(10, unix_now), real_bytes(20000, 70000));
  ASSERT_TRUE(b);

  test::FakeMissionServer::Script script;
  const int a_seq = a->seq, b_seq = b->seq;
  script.hold = [a_seq, b_seq](test::FakeMissionServer& server, const test::ServedPost& post) {
    if (post.seq != b_seq) return;
    server.wait_until([a_seq](const std::vector<test::ServedPost>& posts) {
      for (const test::ServedPost& p : posts)
        if (p.seq == a_seq && p.rev == 1) return true;
      return false;
    });
  };
  test::FakeMissionServer server(script);
  Lanes lanes;
  auto started = start_three_lanes(server, lanes, **box, "refine");
  Sender& sender = *started;
  // Once the refinement's POST has started (its entry is marked attempted first), keyframe C comes.
  const auto attempted = sender.wait_entry(
      a->seq, [](const std::optional<OutboxEntry>& e) { return e && e->rev == 1 && e->attempted; },
      std::chrono::seconds(20));
  ASSERT_TRUE(attempted && attempted->attempted);
  auto c =
      (*box)->add(make(20, std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count()),
                  real_bytes(10000, 90000));
  ASSERT_TRUE(c);
  sender.notify();
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (sender.stats().pending > 0 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  sender.stop();
  close_lanes(lanes);
  server.stop();
  const SenderStats stats = sender.stats();
  const std::vector<PostRecord> log = sender.post_log();
  const double queue_wait_s = sender.queue_wait_s();
  const std::vector<test::ServedPost> posts = server.posts();
  test::remove_tree_quietly(dir);

  EXPECT_EQ(stats.acked, 3u);
  EXPECT_EQ(stats.pending, 0u);
  EXPECT_EQ(stats.refinements_acked, 1u);
  EXPECT_EQ(server.held_too_long(), 0);
  ASSERT_EQ(posts.size(), 3u);  // each stored once, none posted again
  for (const test::ServedPost& p : posts) EXPECT_EQ(p.status, 201) << "seq " << p.seq << " rev " << p.rev;
  const test::ServedPost* ab = find_post(posts, b->seq, 0);
  const test::ServedPost* ar = find_post(posts, a->seq, 1);
  const test::ServedPost* ac = find_post(posts, c->seq, 0);
  ASSERT_TRUE(ab && ar && ac);
  // The refinement started before B's answer: the line carried it while that answer was awaited.
  double refinement_started = 0, b_ended = 0, first_started = 0;
  for (const PostRecord& p : log) {
    if (p.seq == a->seq && p.rev == 1) refinement_started = p.started;
    if (p.seq == b->seq) b_ended = p.ended;
    if (first_started == 0 || p.started < first_started) first_started = p.started;
  }
  ASSERT_GT(refinement_started, 0);
  EXPECT_LT(refinement_started, b_ended);
  EXPECT_LT(ar->body_step, ab->answer_step);
  // C was added while the refinement's body was being written, and its body reached the server first.
  EXPECT_LT(ac->body_step, ar->body_step);
  // The cap held: B's body, then the refinement's 60 kB with C's 10 kB inside it, each at 100 kB/s.
  EXPECT_GE(ar->body_unix_s - first_started, 0.9 * (20000 + 60000 + 10000) / 100e3);
  EXPECT_GT(stats.overlap_s, 0.0);
  // The outbox wait the latency rule counts is the keyframes' (B waited for nothing, C for a chunk or a lane), not
  // the minute since the refined keyframe was first reduced.
  EXPECT_LT(queue_wait_s, 30.0);
}

// Three refinements pending (30 kB each), three lanes, a cap of 800 kbit/s (0.3 s a body) and a server that answers
// a refinement only once the next one's body has come: one refinement's body is written at a time, so their bodies
// reach the server at least one cap-time apart, and the next one starts when the last chunk of the one before is on
// the line, not when its answer comes (else the hold gives up and the test fails). It must not let the third start
// beside the second: their chunks would then share the line and both arrive late.
TEST(SenderLanes, RefinementBodiesAreWrittenOneAtATime) {
  REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz_200_319/rgb/1305031108.843264.png");
  const std::string dir = test::temp_dir("sender_refine_one_at_a_time");
  auto box = Outbox::open(dir, "refine3");
  ASSERT_TRUE(box);
  for (int i = 0; i < 3; ++i) {
    OutboxEntry e;
    e.frame_index = 10 * i;
    e.captured = 1000 + i;
    e.pose = {0.1 * i, 0, 0, 0, 0, 0, 1};
    auto added = (*box)->add(e, real_bytes(5000, 5000 * static_cast<size_t>(i)));
    ASSERT_TRUE(added);
    ASSERT_TRUE((*box)->mark_attempted(added->seq, 1));
    ASSERT_TRUE((*box)->mark_acked(added->seq, "{}"));
    ASSERT_TRUE((*box)->revise(added->seq, real_bytes(30000, 20000 + 30000 * static_cast<size_t>(i)), 30, 100));
  }
  test::FakeMissionServer::Script script;
  script.hold = [](test::FakeMissionServer& server, const test::ServedPost& post) {
    server.wait_until([&post](const std::vector<test::ServedPost>& posts) {
      return posts.size() >= 3 || posts.back().body_step > post.body_step;
    });
  };
  test::FakeMissionServer server(script);
  Lanes lanes;
  auto started = start_three_lanes(server, lanes, **box, "refine3");
  Sender& sender = *started;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (sender.stats().pending > 0 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  sender.stop();
  close_lanes(lanes);
  server.stop();
  const SenderStats stats = sender.stats();
  const std::vector<PostRecord> log = sender.post_log();
  const std::vector<test::ServedPost> posts = server.posts();
  test::remove_tree_quietly(dir);

  EXPECT_EQ(stats.refinements_acked, 3u);
  EXPECT_EQ(stats.pending, 0u);
  EXPECT_EQ(server.held_too_long(), 0);
  ASSERT_EQ(posts.size(), 3u);
  double first_started = 0;
  for (const PostRecord& p : log)
    if (first_started == 0 || p.started < first_started) first_started = p.started;
  EXPECT_GE(posts[0].body_unix_s - first_started, 0.9 * 0.3);
  // One body after the other at the cap, not two sharing it (which brings them nearly together). An arrival is when
  // the server's thread read it, which may be a scheduling delay late: half a body's time is held to.
  for (size_t i = 1; i < posts.size(); ++i) {
    EXPECT_GE(posts[i].body_unix_s - posts[i - 1].body_unix_s, 0.5 * 0.3) << i;
    EXPECT_LT(posts[i].body_step, posts[i - 1].answer_step) << i;  // written while the answer before was awaited
  }
  EXPECT_GT(stats.overlap_s, 0.0);
}

}  // namespace rgbdcast::stream
