// The sender through an outage (stream/sender.h): the server is down, then answers 503 with Retry-After, then
// swallows one answer (the client times out after the keyframe was stored). Every keyframe ends up stored exactly
// once, newest first, the re-post of the stored one is answered 200, and the retries backed off. The server here is
// a minimal httplib server with the contract's idempotency, so that the test can script the failures; the real
// service is exercised end to end in test_stream_cli.cpp.
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <fstream>
#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <thread>

#include "stream/sender.h"
#include "tests/common/test_data.h"

namespace rgbdcast::stream {
namespace {

struct ScriptedServer {
  httplib::Server server;
  std::thread thread;
  std::mutex mu;
  std::map<int, std::string> stored;  // seq -> body
  std::vector<int> created_order;
  int answered_200 = 0, answered_503 = 0, swallowed = 0;
  int fail_with_503 = 2;     // the first requests get 503 Retry-After: 1
  int swallow_answers = 1;   // then one stored keyframe's answer never comes

  void start(int port) {
    server.Post(R"(/v1/missions/([A-Za-z0-9_-]+)/keyframes)", [this](const httplib::Request& req, httplib::Response& res) {
      const int seq = std::stoi(req.get_param_value("seq"));
      bool swallow = false;
      {
        std::lock_guard lock(mu);
        if (fail_with_503 > 0) {
          --fail_with_503;
          ++answered_503;
          res.status = 503;
          res.set_header("Retry-After", "1");
          res.set_content(R"({"error":"busy"})", "application/json");
          return;
        }
        auto it = stored.find(seq);
        if (it == stored.end()) {
          stored[seq] = req.body;
          created_order.push_back(seq);
          res.status = 201;
          if (swallow_answers > 0) {
            --swallow_answers;
            ++swallowed;
            swallow = true;
          }
        } else if (it->second == req.body) {
          res.status = 200;
          ++answered_200;
        } else {
          res.status = 409;
        }
      }
      if (swallow) std::this_thread::sleep_for(std::chrono::seconds(7));  // past the client's timeout (4.5 s here)
      res.set_content("{\"seq\":" + std::to_string(seq) + "}", "application/json");
    });
    thread = std::thread([this, port] { server.listen("127.0.0.1", port); });
    while (!server.is_running()) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ~ScriptedServer() {
    server.stop();
    if (thread.joinable()) thread.join();
  }
};

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

  // Down: connections refused for 1.5 s.
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  const SenderStats down = sender.stats();
  EXPECT_EQ(down.lanes, lanes);
  EXPECT_GE(down.failures, 2u);              // retried, with backoff (0.2, 0.4, 0.8 s ...)
  EXPECT_LE(down.failures, 6u * lanes);      // not a busy loop (the lanes share one backoff)
  EXPECT_TRUE(down.link_down);
  EXPECT_LT(down.estimate_kbps, 500.0);  // failures lowered the estimate
  EXPECT_EQ(down.pending, 3u);

  ScriptedServer server;
  server.start(port);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (sender.stats().pending > 0 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  sender.stop();

  const SenderStats done = sender.stats();
  EXPECT_EQ(done.pending, 0u);
  EXPECT_EQ(done.acked, 3u);
  EXPECT_EQ(done.rejected, 0u);
  std::lock_guard lock(server.mu);
  EXPECT_EQ(server.answered_503, 2);
  EXPECT_EQ(server.swallowed, 1);
  EXPECT_EQ(server.answered_200, 1);  // the keyframe whose answer was lost, re-posted identically
  ASSERT_EQ(server.stored.size(), 3u);
  ASSERT_EQ(server.created_order.size(), 3u);
  if (lanes == 1) {
    EXPECT_EQ(server.created_order.front(), 2);  // newest first
  } else {
    // Newest first, two at a time: the two newest are stored before the oldest (their order is the network's).
    EXPECT_EQ(server.created_order.back() == 0 || server.created_order[1] == 0, true);
    EXPECT_NE(server.created_order.front(), 0);
  }
  for (int seq = 0; seq < 3; ++seq) {
    EXPECT_EQ(server.stored[seq].size(), static_cast<size_t>(3000 + seq));
    EXPECT_TRUE((*box)->entry(seq)->acked);
  }
  test::remove_tree_quietly(dir);
}

TEST(SenderOutage, EveryKeyframeIsStoredExactlyOnceAfterTheLinkReturns) { outage_run(1); }

TEST(SenderOutage, EveryKeyframeIsStoredExactlyOnceWithTwoPostsInFlight) { outage_run(2); }

// Two lanes against a server that answers each POST 300 ms after reading it (a round trip plus the service's
// time): the second POST crosses while the first one's answer is outstanding, bodies are paced back to back at
// the cap (the server sees them start no closer than bytes / cap), never more than two are in flight, and all six
// are stored exactly once, in less time than one lane needs.
TEST(SenderLanes, TwoPostsInFlightArePacedAtTheCapAndStoredExactlyOnce) {
  struct Run {
    double seconds = 0;
    SenderStats stats;
    std::vector<double> arrivals;  // steady seconds when the server had each POST's body
    std::vector<size_t> sizes;
    int max_concurrent = 0;
    std::map<int, int> stored;     // seq -> times created
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
    httplib::Server server;
    std::mutex mu;
    int concurrent = 0;
    server.Post(R"(/v1/missions/([A-Za-z0-9_-]+)/keyframes)", [&](const httplib::Request& req, httplib::Response& res) {
      const int seq = std::stoi(req.get_param_value("seq"));
      {
        std::lock_guard lock(mu);
        out.arrivals.push_back(
            std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count());
        out.sizes.push_back(req.body.size());
        out.max_concurrent = std::max(out.max_concurrent, ++concurrent);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(300));
      std::lock_guard lock(mu);
      --concurrent;
      res.status = out.stored[seq]++ == 0 ? 201 : 200;
      res.set_content("{\"seq\":" + std::to_string(seq) + "}", "application/json");
    });
    const int port = server.bind_to_any_port("127.0.0.1");
    std::thread t([&] { server.listen_after_bind(); });
    Lanes lane_uplinks = make_lanes(port, lanes);
    SenderParams sp;
    sp.mission = "lanes";
    sp.link.cap_kbps = 800;  // 10 kB: 0.1 s at the cap
    const auto t0 = std::chrono::steady_clock::now();
    Sender sender(**box, lane_uplinks.uplinks, sp);
    sender.start();
    const auto deadline = t0 + std::chrono::seconds(30);
    while (sender.stats().pending > 0 && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    sender.stop();
    out.stats = sender.stats();
    server.stop();
    t.join();
    test::remove_tree_quietly(dir);
    return out;
  };
  const Run one = run(1), two = run(2);
  for (const Run* r : {&one, &two}) {
    EXPECT_EQ(r->stats.acked, 6u);
    EXPECT_EQ(r->stats.pending, 0u);
    ASSERT_EQ(r->stored.size(), 6u);
    for (const auto& [seq, times] : r->stored) EXPECT_EQ(times, 1) << "seq " << seq;  // no re-post was needed
    ASSERT_EQ(r->arrivals.size(), 6u);
    // Paced at the cap: over the run, the bodies come no faster than the cap carries them. An arrival is when the
    // handler ran, so one gap may be a scheduling delay short (a pair 84 ms apart against 90 under ctest -j2); each
    // gap is held to half its body's time at the cap, which an unpaced sender (two lanes at once) does not meet.
    double line_s = 0;
    for (size_t i = 1; i < r->arrivals.size(); ++i) {
      const double body_s = r->sizes[i - 1] * 8.0 / 800e3;
      line_s += body_s;
      EXPECT_GE(r->arrivals[i] - r->arrivals[i - 1], 0.5 * body_s) << i;
    }
    EXPECT_GE(r->arrivals.back() - r->arrivals.front(), 0.9 * line_s);
  }
  EXPECT_EQ(one.max_concurrent, 1);
  EXPECT_EQ(two.max_concurrent, 2);
  EXPECT_EQ(one.stats.overlap_s, 0.0);
  EXPECT_GT(two.stats.overlap_s, 0.5);
  // One lane: six answers of >= 0.3 s one after another. Two: about half of that.
  EXPECT_GE(one.seconds, 1.8);
  EXPECT_LT(two.seconds, 0.75 * one.seconds);
  // Busy time is the union of the lanes' POSTs: never more than the run took.
  EXPECT_LE(two.stats.busy_s, two.seconds + 0.05);
  EXPECT_GT(two.stats.busy_s, 0.9);
}

TEST(SenderOutage, ARefusedTokenStopsTheSender) {
  const std::string dir = test::temp_dir("sender_token");
  auto box = Outbox::open(dir, "auth");
  ASSERT_TRUE(box);
  ASSERT_TRUE((*box)->add(OutboxEntry{}, std::vector<std::uint8_t>(100, 1)));
  httplib::Server server;
  server.Post(R"(/v1/missions/.*)", [](const httplib::Request&, httplib::Response& res) {
    res.status = 401;
    res.set_content(R"({"error":"unauthorized","message":"bad token"})", "application/json");
  });
  const int port = server.bind_to_any_port("127.0.0.1");
  std::thread t([&] { server.listen_after_bind(); });
  UplinkOptions uo;
  uo.server_url = "http://127.0.0.1:" + std::to_string(port);
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
  server.stop();
  t.join();
  test::remove_tree_quietly(dir);
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

// Starts `server` on its own thread and a sender with three lanes to it (two for keyframes, as rgbdcast stream gives
// refinements one more) at a cap of 800 kbit/s (100 kB/s: 0.1 s per 10 kB).
std::unique_ptr<Sender> start_three_lanes(httplib::Server& server, std::thread& server_thread, Lanes& lanes,
                                          Outbox& box, const std::string& mission) {
  const int port = server.bind_to_any_port("127.0.0.1");
  server_thread = std::thread([&server] { server.listen_after_bind(); });
  lanes = make_lanes(port, 3);
  SenderParams sp;
  sp.mission = mission;
  sp.link.cap_kbps = 800;
  sp.max_first_in_flight = 2;
  auto sender = std::make_unique<Sender>(box, lanes.uplinks, sp);
  sender->start();
  return sender;
}

}  // namespace

// Three lanes (two for keyframes, as rgbdcast stream gives refinements one more), a cap of 800 kbit/s (100 kB/s) and
// a server that answers each POST 1 s after reading its body. Pending at the start: keyframe B's first revision
// (20 kB) and a refinement of keyframe A (rev 1, 60 kB). B goes first; the refinement starts once B's body is on
// the line, before B's answer (the line carries it while that answer is awaited); keyframe C (10 kB), added while the
// refinement's body is being written, goes ahead of the rest of it (its body reaches the server first), and the
// refinement's body still takes its bytes and C's at the cap (the cap holds). Everything is stored once.
TEST(SenderLanes, ARefinementFillsTheWaitForAnAnswerAndANewKeyframeOvertakesIt) {
  REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz_200_319/rgb/1305031108.843264.png");
  const std::string dir = test::temp_dir("sender_refine_lane");
  auto box = Outbox::open(dir, "refine");
  ASSERT_TRUE(box);
  const double unix_now =
      std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
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

  struct Arrival {
    int seq, rev;
    double body_s, answer_s;  // steady seconds: the body was read; the answer was sent
  };
  std::mutex mu;
  std::vector<Arrival> arrivals;
  std::map<std::pair<int, int>, int> stored;  // (seq, rev) -> times created
  httplib::Server server;
  auto now_s = [] { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); };
  server.Post(R"(/v1/missions/([A-Za-z0-9_-]+)/keyframes)", [&](const httplib::Request& req, httplib::Response& res) {
    const int seq = std::stoi(req.get_param_value("seq"));
    const int rev = req.has_param("rev") ? std::stoi(req.get_param_value("rev")) : 0;
    const double body_s = now_s();
    std::this_thread::sleep_for(std::chrono::seconds(1));
    std::lock_guard lock(mu);
    arrivals.push_back({seq, rev, body_s, now_s()});
    res.status = stored[{seq, rev}]++ == 0 ? 201 : 200;
    res.set_content("{\"seq\":" + std::to_string(seq) + ",\"rev\":" + std::to_string(rev) + "}", "application/json");
  });
  std::thread t;
  Lanes lanes;
  const double t0 = now_s();
  auto started = start_three_lanes(server, t, lanes, **box, "refine");
  Sender& sender = *started;
  // Once the refinement's POST has started (its entry is marked attempted first), keyframe C comes.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (!(*box)->entry(a->seq)->attempted && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  const double c_added = now_s();
  auto c = (*box)->add(
      make(20, std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count()),
      real_bytes(10000, 90000));
  ASSERT_TRUE(c);
  sender.notify();
  while (sender.stats().pending > 0 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  sender.stop();
  const SenderStats stats = sender.stats();
  const std::vector<PostRecord> log = sender.post_log();
  const double queue_wait_s = sender.queue_wait_s();
  server.stop();
  t.join();
  test::remove_tree_quietly(dir);

  EXPECT_EQ(stats.acked, 3u);
  EXPECT_EQ(stats.pending, 0u);
  EXPECT_EQ(stats.refinements_acked, 1u);
  ASSERT_EQ(stored.size(), 3u);
  for (const auto& [key, times] : stored) EXPECT_EQ(times, 1) << "seq " << key.first << " rev " << key.second;
  ASSERT_EQ(arrivals.size(), 3u);
  auto find = [&](int seq, int rev) {
    for (const Arrival& x : arrivals)
      if (x.seq == seq && x.rev == rev) return x;
    ADD_FAILURE() << "seq " << seq << " rev " << rev << " never arrived";
    return Arrival{seq, rev, 0, 0};
  };
  const Arrival ab = find(b->seq, 0), ar = find(a->seq, 1), ac = find(c->seq, 0);
  // The refinement started before B's answer: the line carried it while that answer was awaited.
  double refinement_started = 0;
  for (const PostRecord& p : log)
    if (p.seq == a->seq && p.rev == 1) refinement_started = p.started;
  ASSERT_GT(refinement_started, 0);
  double b_ended = 0;
  for (const PostRecord& p : log)
    if (p.seq == b->seq) b_ended = p.ended;
  EXPECT_LT(refinement_started, b_ended);
  EXPECT_LT(ar.body_s, ab.answer_s);
  // C was added while the refinement's body was being written, and its body reached the server first.
  EXPECT_GT(c_added, t0);
  EXPECT_LT(ac.body_s, ar.body_s);
  // The cap held: B's body, then the refinement's 60 kB with C's 10 kB inside it, each at 100 kB/s.
  EXPECT_GE(ar.body_s - t0, 0.9 * (20000 + 60000 + 10000) / 100e3);
  EXPECT_GT(stats.overlap_s, 0.5);
  // The outbox wait the latency rule counts is the keyframes' (B waited for nothing, C for a chunk or a lane), not
  // the minute since the refined keyframe was first reduced.
  EXPECT_LT(queue_wait_s, 2.0);
}


// Three refinements pending (30 kB each), three lanes, a cap of 800 kbit/s (0.3 s a body) and a server that answers
// 0.2 s after reading one: one refinement's body is written at a time, so their bodies reach the server one cap-time
// apart, although the first one's answer comes while the second is being written (it must not let the third start
// beside the second: their chunks would then share the line and both arrive late).
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
  std::mutex mu;
  std::vector<double> arrivals;
  httplib::Server server;
  auto now_s = [] { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); };
  server.Post(R"(/v1/missions/([A-Za-z0-9_-]+)/keyframes)", [&](const httplib::Request&, httplib::Response& res) {
    {
      std::lock_guard lock(mu);
      arrivals.push_back(now_s());
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    res.status = 201;
    res.set_content("{}", "application/json");
  });
  std::thread t;
  Lanes lanes;
  const double t0 = now_s();
  auto started = start_three_lanes(server, t, lanes, **box, "refine3");
  Sender& sender = *started;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (sender.stats().pending > 0 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  sender.stop();
  const SenderStats stats = sender.stats();
  server.stop();
  t.join();
  test::remove_tree_quietly(dir);

  EXPECT_EQ(stats.refinements_acked, 3u);
  EXPECT_EQ(stats.pending, 0u);
  ASSERT_EQ(arrivals.size(), 3u);
  std::sort(arrivals.begin(), arrivals.end());
  EXPECT_GE(arrivals[0] - t0, 0.9 * 0.3);
  for (size_t i = 1; i < arrivals.size(); ++i)  // one body after the other at the cap, not two sharing it
    EXPECT_GE(arrivals[i] - arrivals[i - 1], 0.9 * 0.3) << i;
  // The first two answers (0.2 s each) were awaited while the next body was written: 0.38 s in three runs. Before
  // the lanes were woken when a body's last chunk was written, the next body waited for a 200 ms poll, and this was
  // under 0.1 s in 3 of 16 runs (0.046 and 0.086 s where seen).
  EXPECT_GT(stats.overlap_s, 0.3);
}

}  // namespace rgbdcast::stream
