// Three replicas on PostgreSQL behind nginx, as deploy/cluster.sh starts them (loopback; every process it starts is
// in its pid files, and `down` stops exactly those): views of a mission come from one replica and 300 ids spread over
// the three; a keyframe posted through the front is an event for an SSE client of the front whichever replica holds
// it; a kill -9 of the replica serving a mission under 8 clients costs few views, views come back from another
// replica, and posts through the front land once each.
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <map>
#include <random>
#include <thread>

#include <nlohmann/json.hpp>

#include "base/stopwatch.h"
#include "tests/common/run_command.h"
#include "tests/common/test_data.h"
#include "tests/service/mission_keyframes.h"
#include "tests/service/raw_http.h"

using nlohmann::json;
using rgbdcast::test::MissionKeyframeFile;

using rgbdcast::ms_since;

namespace {

constexpr int kReplicas = 3;

bool port_free(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const bool ok = ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  ::close(fd);
  return ok;
}

// A base port with itself and the replicas' ports above it free now.
int free_port_block() {
  std::mt19937 rng(static_cast<unsigned>(::getpid()) ^ static_cast<unsigned>(std::random_device{}()));
  for (int attempt = 0; attempt < 200; ++attempt) {
    const int base = 20000 + static_cast<int>(rng() % 20000);
    bool all = true;
    for (int i = 0; i <= kReplicas && all; ++i) all = port_free(base + i);
    if (all) return base;
  }
  return 0;
}

std::string script() { return std::string(RGBDCAST_SOURCE_DIR) + "/deploy/cluster.sh"; }

// The cluster of one test: up in a fresh folder, down (and the folder removed when the test passed) at the end.
class Cluster {
 public:
  bool up(std::string* error) {
    dir_ = rgbdcast::test::temp_dir("cluster");
    port_ = free_port_block();
    if (port_ == 0) {
      *error = "no free block of ports";
      return false;
    }
    // One renderer each: three replicas and nginx share two cores.
    auto r = rgbdcast::test::run_command("RGBDCAST_BIN=" + rgbdcast::test::rgbdcast_binary() + " timeout 180 " +
                                         script() + " up " + dir_ + " --replicas " + std::to_string(kReplicas) +
                                         " --port " + std::to_string(port_) + " -- --renderers 1");
    started_ = true;
    *error = r.out + r.err;
    return r.exit_code == 0 && r.out.find("http://127.0.0.1:" + std::to_string(port_)) != std::string::npos;
  }
  ~Cluster() {
    if (!started_) return;
    auto r = rgbdcast::test::run_command("timeout 120 " + script() + " down " + dir_);
    EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
    for (const char* f : {"/nginx.pid", "/postgres.pid", "/replica-1.pid"})
      EXPECT_FALSE(std::ifstream(dir_ + f).good()) << f << " left behind";
    if (!::testing::Test::HasFailure()) rgbdcast::test::remove_tree_quietly(dir_);
  }
  int port() const { return port_; }
  pid_t replica_pid(const std::string& name) const {
    std::ifstream in(dir_ + "/replica-" + name + ".pid");
    pid_t pid = -1;
    in >> pid;
    return pid;
  }
  std::unique_ptr<httplib::Client> client() const {
    auto c = std::make_unique<httplib::Client>("127.0.0.1", port_);
    c->set_read_timeout(30, 0);
    c->set_connection_timeout(5, 0);
    return c;
  }

 private:
  std::string dir_;
  int port_ = 0;
  bool started_ = false;
};

httplib::Result post_keyframe(httplib::Client& c, const std::string& mission, int seq, const MissionKeyframeFile& k) {
  const std::string path = "/v1/missions/" + mission + "/keyframes?seq=" + std::to_string(seq) + "&pose=" + k.pose;
  return c.Post(path.c_str(), k.glb, "model/gltf-binary");
}

std::string view_path(const std::string& mission) {
  return "/v1/missions/" + mission + "/view?pose=capture&width=64&height=48";
}

#define REQUIRE_CLUSTER(cluster)                                                                              \
  do {                                                                                                        \
    REQUIRE_DATA(rgbdcast::test::kMissionExcerpt);                                                            \
    ASSERT_EQ(rgbdcast::test::four_mission_keyframes().size(), 4u);                                           \
    std::string why_;                                                                                         \
    if (::access("/usr/sbin/nginx", X_OK) != 0 || ::access("/usr/lib/postgresql/15/bin/postgres", X_OK) != 0) \
      RGBDCAST_MISSING_PREREQUISITE("nginx and PostgreSQL 15 (scripts/setup.sh test)");                       \
    ASSERT_TRUE((cluster).up(&why_)) << why_;                                                                 \
  } while (0)

}  // namespace

TEST(Cluster, AffinityEventsAndFailoverBehindNginx) {
  Cluster cluster;
  REQUIRE_CLUSTER(cluster);
  auto c = cluster.client();

  // Affinity: 300 ids over 3 replicas, each id answered by one replica every time.
  std::map<std::string, int> per_replica;
  for (int i = 0; i < 300; ++i) {
    const std::string path = "/v1/missions/affinity-" + std::to_string(i);
    auto r = c->Get(path.c_str());
    ASSERT_TRUE(r) << path;
    EXPECT_EQ(r->status, 404) << r->body;
    const std::string replica = r->get_header_value("X-Rgbdcast-Replica");
    ++per_replica[replica];
    if (i % 50 == 0) {
      auto again = c->Get(path.c_str());
      ASSERT_TRUE(again);
      EXPECT_EQ(again->get_header_value("X-Rgbdcast-Replica"), replica) << path;
    }
  }
  ASSERT_EQ(per_replica.size(), static_cast<size_t>(kReplicas));
  for (const auto& [replica, n] : per_replica) {
    EXPECT_GE(n, 60) << "replica " << replica;   // 20 % of 300
    EXPECT_LE(n, 141) << "replica " << replica;  // 47 % of 300
  }

  // A keyframe posted through the front is an event for an SSE client of the front.
  const auto& k = rgbdcast::test::four_mission_keyframes();
  const std::string mission = "front";
  ASSERT_EQ(post_keyframe(*c, mission, 0, k[0])->status, 201);
  bool known = false;
  for (int i = 0; i < 200 && !known; ++i) {
    auto r = c->Get(("/v1/missions/" + mission).c_str());
    known = r && r->status == 200;
    if (!known) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_TRUE(known);
  std::string seen;
  std::thread listener([&] {
    seen =
        rgbdcast::test::read_event_stream_until(cluster.port(), "/v1/missions/" + mission + "/events", "id: 1\n", 30.0);
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  const auto posted = std::chrono::steady_clock::now();
  ASSERT_EQ(post_keyframe(*c, mission, 1, k[1])->status, 201);
  listener.join();
  const double event_ms = ms_since(posted);
  EXPECT_NE(seen.find("id: 1\n"), std::string::npos) << seen;
  std::printf("keyframe POST through the front to its SSE event through the front: %.0f ms\n", event_ms);

  // The replica serving the mission's views, killed (-9) while 8 clients view it.
  auto v = c->Get(view_path(mission).c_str());
  ASSERT_TRUE(v);
  ASSERT_EQ(v->status, 200) << v->body;
  const std::string serving = v->get_header_value("X-Rgbdcast-Replica");
  const pid_t victim = cluster.replica_pid(serving);
  ASSERT_GT(victim, 0);
  std::atomic<int> done{0}, failed{0};
  std::atomic<bool> killed{false};
  std::vector<std::thread> clients;
  for (int t = 0; t < 8; ++t) {
    clients.emplace_back([&] {
      auto own = cluster.client();
      for (int i = 0; i < 5; ++i) {
        if (done.fetch_add(1) == 8) {  // the ninth view of 40: the replica dies under load
          ::kill(victim, SIGKILL);
          killed = true;
        }
        auto r = own->Get(view_path(mission).c_str());
        if (!r || r->status != 200) ++failed;
      }
    });
  }
  for (auto& t : clients) t.join();
  ASSERT_TRUE(killed);
  EXPECT_LE(failed.load(), 5) << "of 40 views";
  std::printf("views failed of 40 with replica %s killed under 8 clients: %d\n", serving.c_str(), failed.load());
  // Views come back from another replica (bounded), and posts through the front land once each.
  std::string after;
  for (int i = 0; i < 100 && after.empty(); ++i) {
    auto r = c->Get(view_path(mission).c_str());
    if (r && r->status == 200)
      after = r->get_header_value("X-Rgbdcast-Replica");
    else
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_FALSE(after.empty()) << "no view succeeded after the kill";
  EXPECT_NE(after, serving);
  for (int seq = 2; seq < 4; ++seq) {
    auto r = post_keyframe(*c, mission, seq, k[static_cast<size_t>(seq)]);
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 201) << r->body;
    EXPECT_NE(r->get_header_value("X-Rgbdcast-Replica"), serving);
  }
  auto listed = c->Get(("/v1/missions/" + mission).c_str());
  ASSERT_TRUE(listed);
  ASSERT_EQ(listed->status, 200);
  std::vector<int> seqs;
  const json held = json::parse(listed->body);
  for (const auto& kf : held["keyframes"]) seqs.push_back(kf["seq"].get<int>());
  EXPECT_EQ(seqs, (std::vector<int>{0, 1, 2, 3})) << listed->body;
}
