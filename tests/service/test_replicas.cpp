// Replicas of the real `rgbdcast serve`: every response names its replica (X-Rgbdcast-Replica), /livez and /readyz
// say what is up, SIGTERM drains before the stop, and two replicas on one PostgreSQL store (--store postgresql://...,
// a throwaway server this program starts: tests/common/postgres_server.h) share their missions: a keyframe posted
// to one is an event and a view on the other, and a re-post through the other is idempotent; a replica that takes a
// mission over loads its tiles from the rows.
#include <gtest/gtest.h>
#include <httplib.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <map>
#include <thread>

#include <nlohmann/json.hpp>

#include "tests/common/postgres_server.h"
#include "tests/common/test_data.h"
#include "tests/service/mission_keyframes.h"
#include "tests/service/raw_http.h"
#include "tests/service/server_process.h"

using nlohmann::json;
using rgbdcast::test::MissionKeyframeFile;
using rgbdcast::test::ServerProcess;

namespace {

std::unique_ptr<httplib::Client> client(int port) {
  auto c = std::make_unique<httplib::Client>("127.0.0.1", port);
  c->set_read_timeout(60, 0);
  return c;
}

httplib::Result post_keyframe(httplib::Client& c, const std::string& mission, int seq, const MissionKeyframeFile& k,
                              const std::string& body) {
  const std::string path = "/v1/missions/" + mission + "/keyframes?seq=" + std::to_string(seq) + "&pose=" + k.pose;
  return c.Post(path.c_str(), body, "model/gltf-binary");
}

// A test's folder, removed at the end when the test passed (declared before the servers, so removed after they stop).
struct TestDir {
  std::string path;
  explicit TestDir(const std::string& tag) : path(rgbdcast::test::temp_dir(tag)) {}
  ~TestDir() {
    if (!::testing::Test::HasFailure()) rgbdcast::test::remove_tree_quietly(path);
  }
};

// A PNG view of mission "shared" once it is drawn from its settled tileset alone (no pending keyframe, no inner tile
// waiting to be rebuilt: two replicas then draw the same image), at most 30 s; empty when it never is.
std::string tileset_view(httplib::Client& c) {
  for (int i = 0; i < 300; ++i) {
    auto v = c.Get("/v1/missions/shared/view?pose=capture&width=64&height=48&format=png");
    if (v && v->status == 200 && v->get_header_value("X-Pending-Keyframes") == "0" &&
        v->get_header_value("X-Tileset-Version") != "0" && v->get_header_value("X-Stale-Tiles") == "0")
      return v->body;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return "";
}

}  // namespace

TEST(Replicas, EveryResponseNamesItsReplicaAndHealthSaysWhatIsUp) {
  const TestDir dir("replica-health");
  ServerProcess server;
  std::string error;
  ASSERT_TRUE(server.start(dir.path, {"--replica", "r1"}, &error)) << error;
  auto c = client(server.port());
  // Answers of the routes, of the HTTP layer (no route, a method the route does not allow) and of health.
  const struct {
    const char* method;
    const char* path;
    int status;
  } cases[] = {{"GET", "/livez", 200},
               {"GET", "/readyz", 200},
               {"GET", "/v1/missions/no-such-mission", 404},
               {"GET", "/no/such/route", 404},
               {"DELETE", "/readyz", 405}};
  for (const auto& t : cases) {
    auto r = std::string(t.method) == "GET" ? c->Get(t.path) : c->Delete(t.path);
    ASSERT_TRUE(r) << t.method << " " << t.path;
    EXPECT_EQ(r->status, t.status) << t.method << " " << t.path << ": " << r->body;
    EXPECT_EQ(r->get_header_value("X-Rgbdcast-Replica"), "r1") << t.method << " " << t.path;
  }
  const json r = json::parse(c->Get("/readyz")->body);
  EXPECT_EQ(r["status"], "ready");
  EXPECT_EQ(r["store"], "directory");
  EXPECT_EQ(r["checks"], json({{"scenes", "ok"}, {"missions", "ok"}, {"renderer", "ok"}, {"draining", "ok"}}));
  // A name that could not be a header value is refused at start.
  ServerProcess bad;
  EXPECT_FALSE(bad.start(dir.path + "/bad", {"--replica", "a b"}, &error, 30.0));
  EXPECT_NE(error.find("replica name"), std::string::npos) << error;
}

// SIGTERM: /readyz turns 503 ("draining") while requests are still answered for --drain-s, then the process exits 0.
TEST(Replicas, SigtermDrainsThenStops) {
  const TestDir dir("replica-drain");
  ServerProcess server;
  std::string error;
  ASSERT_TRUE(server.start(dir.path, {"--replica", "d", "--drain-s", "3"}, &error)) << error;
  auto c = client(server.port());
  ASSERT_EQ(c->Get("/readyz")->status, 200);
  ASSERT_EQ(::kill(server.pid(), SIGTERM), 0);
  int draining = 0;
  for (int i = 0; i < 100 && draining == 0; ++i) {
    auto r = c->Get("/readyz");
    if (r && r->status == 503) {
      const json body = json::parse(r->body);
      EXPECT_NE(body["checks"]["draining"], "ok") << r->body;
      EXPECT_EQ(c->Get("/livez")->status, 200);  // still serving while draining
      draining = 1;
    } else {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
  EXPECT_EQ(draining, 1) << "never saw /readyz answer 503 after SIGTERM";
  const int status = server.stop(30.0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status << " " << server.output();
}

// A --store that is neither "directory" nor a PostgreSQL URI, or a database that cannot be reached: a one-line error
// at start, nothing served.
TEST(Replicas, ABadOrUnreachableStoreIsAOneLineErrorAtStart) {
  const TestDir dir("replica-bad-store");
  std::string error;
  ServerProcess bogus;
  EXPECT_FALSE(bogus.start(dir.path + "/a", {"--store", "mysql://x"}, &error, 30.0));
  EXPECT_NE(error.find("--store must be"), std::string::npos) << error;
  ServerProcess unreachable;
  error.clear();
  EXPECT_FALSE(unreachable.start(
      dir.path + "/b", {"--store", "postgresql:///none?host=" + dir.path + "/no-socket-here&connect_timeout=2"}, &error,
      30.0));
  EXPECT_NE(error.find("postgresql: cannot connect"), std::string::npos) << error;
}

// Two replicas on one database: a keyframe posted to A is an SSE event and a view on B (B's listener applied the
// change, B's tile worker built the tileset from the rows), a re-post through B answers as a re-post (200), and
// another body for the same (seq, rev) is a 409 whichever replica stored it. Then B restarted with an empty cache,
// and the database restarted under both.
TEST(Replicas, AKeyframePostedToOneReplicaIsAnEventAndAViewOnTheOtherAcrossRestarts) {
  REQUIRE_DATA(rgbdcast::test::kMissionExcerpt);
  ASSERT_EQ(rgbdcast::test::four_mission_keyframes().size(), 4u);
  const auto uri = rgbdcast::test::fresh_database();
  if (!uri) RGBDCAST_MISSING_PREREQUISITE("postgres: " + uri.error().message);
  const TestDir dir("replica-pg");
  ServerProcess a, b;
  std::string error;
  ASSERT_TRUE(a.start(dir.path + "/a", {"--store", *uri, "--replica", "a"}, &error)) << error;
  ASSERT_TRUE(b.start(dir.path + "/b", {"--store", *uri, "--replica", "b"}, &error)) << error;
  auto ca = client(a.port());
  auto cb = client(b.port());
  auto ready = cb->Get("/readyz");
  ASSERT_TRUE(ready);
  EXPECT_EQ(ready->status, 200) << ready->body;
  EXPECT_EQ(json::parse(ready->body)["store"], "postgresql");

  const auto& k = rgbdcast::test::four_mission_keyframes();
  auto first = post_keyframe(*ca, "shared", 0, k[0], k[0].glb);
  ASSERT_TRUE(first);
  EXPECT_EQ(first->status, 201) << first->body;
  EXPECT_EQ(first->get_header_value("X-Rgbdcast-Replica"), "a");
  // B learns of the mission through its listener (bounded wait), then streams its events while A stores the next.
  bool known = false;
  for (int i = 0; i < 200 && !known; ++i) {
    auto r = cb->Get("/v1/missions/shared");
    known = r && r->status == 200;
    if (!known) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_TRUE(known) << "replica b never learnt of the mission";
  std::string seen;
  std::thread listener(
      [&] { seen = rgbdcast::test::read_event_stream_until(b.port(), "/v1/missions/shared/events", "id: 1\n", 60.0); });
  auto second = post_keyframe(*ca, "shared", 1, k[1], k[1].glb);
  ASSERT_TRUE(second);
  EXPECT_EQ(second->status, 201) << second->body;
  listener.join();
  EXPECT_NE(seen.find("id: 0\n"), std::string::npos) << seen;
  EXPECT_NE(seen.find("id: 1\n"), std::string::npos) << seen;
  EXPECT_NE(seen.find("X-Rgbdcast-Replica: b"), std::string::npos) << seen;

  auto listed = cb->Get("/v1/missions/shared");
  ASSERT_TRUE(listed);
  ASSERT_EQ(listed->status, 200) << listed->body;
  EXPECT_EQ(json::parse(listed->body)["keyframes"].size(), 2u) << listed->body;
  // B renders the mission from the rows (its own tile cache, built from what A stored).
  EXPECT_FALSE(tileset_view(*cb).empty()) << "replica b never drew the mission from its tileset";
  auto again = post_keyframe(*cb, "shared", 1, k[1], k[1].glb);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->status, 200) << again->body;
  auto conflict = post_keyframe(*cb, "shared", 1, k[1], k[0].glb);
  ASSERT_TRUE(conflict);
  EXPECT_EQ(conflict->status, 409) << conflict->body;
  EXPECT_EQ(conflict->get_header_value("X-Rgbdcast-Replica"), "b");

  // B restarted with an empty tile cache draws what A draws (the same PNG), from the rows alone.
  const std::string from_a = tileset_view(*ca);
  ASSERT_FALSE(from_a.empty());
  ASSERT_EQ(b.stop(), 0) << b.output();
  rgbdcast::test::remove_tree_quietly(dir.path + "/b");
  ASSERT_TRUE(b.start(dir.path + "/b", {"--store", *uri, "--replica", "b"}, &error)) << error;
  cb = client(b.port());
  EXPECT_EQ(tileset_view(*cb), from_a) << "replica b restarted with an empty cache draws another image";

  // The database killed (-9) and started again: both replicas reconnect; a keyframe posted through A afterwards
  // (retried while A's connections are made again) reaches B, and each replica holds every keyframe once.
  std::string why;
  const auto restarted = rgbdcast::test::shared_postgres(&why)->restart();
  ASSERT_TRUE(restarted) << restarted.error().message;
  int status = 0;
  for (int attempt = 0; attempt < 20 && status != 201; ++attempt) {
    auto r = post_keyframe(*ca, "shared", 2, k[2], k[2].glb);
    status = r ? r->status : 0;
    if (status != 201) std::this_thread::sleep_for(std::chrono::milliseconds(250));
  }
  EXPECT_EQ(status, 201);
  for (auto* c : {ca.get(), cb.get()}) {
    std::vector<int> seqs;
    for (int i = 0; i < 100 && seqs.size() < 3; ++i) {
      auto r = c->Get("/v1/missions/shared");
      seqs.clear();
      if (r && r->status == 200) {
        const json held = json::parse(r->body);
        for (const auto& kf : held["keyframes"]) seqs.push_back(kf["seq"].get<int>());
      }
      if (seqs.size() < 3) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    EXPECT_EQ(seqs, (std::vector<int>{0, 1, 2}));
  }
  EXPECT_EQ(cb->Get("/readyz")->status, 200);
}

namespace {

// The tileset version of `mission` once its view is drawn from its settled tileset alone (no pending keyframe, no
// stale tile), at most 60 s; empty when it never is.
std::string settled_tileset_version(httplib::Client& c, const std::string& mission) {
  const std::string path = "/v1/missions/" + mission + "/view?pose=capture&width=64&height=48&format=png";
  for (int i = 0; i < 600; ++i) {
    auto v = c.Get(path.c_str());
    if (v && v->status == 200 && v->get_header_value("X-Pending-Keyframes") == "0" &&
        v->get_header_value("X-Tileset-Version") != "0" && v->get_header_value("X-Stale-Tiles") == "0")
      return v->get_header_value("X-Tileset-Version");
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return "";
}

// The content URIs of a tileset.json, depth first.
void content_uris(const json& tile, std::vector<std::string>* out) {
  if (tile.contains("content")) out->push_back(tile["content"]["uri"].get<std::string>());
  if (tile.contains("children"))
    for (const auto& child : tile["children"]) content_uris(child, out);
}

// tileset.json and every tile it names, as one replica serves them.
std::map<std::string, std::string> tileset_files(httplib::Client& c, const std::string& mission) {
  std::map<std::string, std::string> out;
  const std::string base = "/v1/missions/" + mission + "/";
  auto tileset = c.Get((base + "tileset.json").c_str());
  if (!tileset || tileset->status != 200) return out;
  out["tileset.json"] = tileset->body;
  std::vector<std::string> uris;
  content_uris(json::parse(tileset->body)["root"], &uris);
  for (const auto& uri : uris) {
    auto tile = c.Get((base + uri).c_str());
    out[uri] = tile && tile->status == 200 ? tile->body : "(" + std::to_string(tile ? tile->status : 0) + ")";
  }
  return out;
}

}  // namespace

// Failover: the replica that built a mission's tiles is killed and its disk lost; a new replica with an empty
// --data-dir serves the same tileset and tiles, loaded from the rows: it settles at the very version A committed
// (a tile it built would be a commit of a later version), and its metrics count no tile built and one hierarchy
// loaded.
TEST(Replicas, AReplicaTakingAMissionOverLoadsItsTilesFromTheRowsInsteadOfBuildingThem) {
  REQUIRE_DATA(rgbdcast::test::kMissionExcerpt);
  ASSERT_EQ(rgbdcast::test::four_mission_keyframes().size(), 4u);
  const auto uri = rgbdcast::test::fresh_database();
  if (!uri) RGBDCAST_MISSING_PREREQUISITE("postgres: " + uri.error().message);
  const TestDir dir("replica-takeover");
  ServerProcess a, b;
  std::string error;
  ASSERT_TRUE(a.start(dir.path + "/a", {"--store", *uri, "--replica", "a"}, &error)) << error;
  auto ca = client(a.port());
  const auto& k = rgbdcast::test::four_mission_keyframes();
  for (int seq = 0; seq < 4; ++seq) {
    auto r = post_keyframe(*ca, "takeover", seq, k[static_cast<size_t>(seq)], k[static_cast<size_t>(seq)].glb);
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 201) << r->body;
  }
  const std::string version = settled_tileset_version(*ca, "takeover");
  ASSERT_FALSE(version.empty()) << "replica a never settled the mission's tileset";
  const auto from_a = tileset_files(*ca, "takeover");
  ASSERT_GT(from_a.size(), 4u) << "tileset.json and at least one tile per keyframe";
  a.kill9();
  rgbdcast::test::remove_tree_quietly(dir.path + "/a");

  ASSERT_TRUE(b.start(dir.path + "/b", {"--store", *uri, "--replica", "b"}, &error)) << error;
  auto cb = client(b.port());
  EXPECT_EQ(settled_tileset_version(*cb, "takeover"), version) << "replica b built tiles again:\n" << b.output();
  const auto from_b = tileset_files(*cb, "takeover");
  EXPECT_EQ(from_b.size(), from_a.size());
  for (const auto& [file, bytes] : from_a) {
    auto it = from_b.find(file);
    ASSERT_NE(it, from_b.end()) << file;
    EXPECT_TRUE(it->second == bytes) << file << " differs between the replicas";
  }
  auto tileset = cb->Get("/v1/missions/takeover/tileset.json");
  ASSERT_TRUE(tileset);
  EXPECT_EQ(tileset->get_header_value("ETag"), "\"tileset-" + version + "\"");
  auto metrics = cb->Get("/metrics");
  ASSERT_TRUE(metrics);
  EXPECT_NE(metrics->body.find("\nrgbdcast_tiles_built_total{kind=\"leaf\"} 0\n"), std::string::npos) << metrics->body;
  EXPECT_NE(metrics->body.find("\nrgbdcast_tiles_built_total{kind=\"inner\"} 0\n"), std::string::npos) << metrics->body;
  EXPECT_NE(metrics->body.find("\nrgbdcast_tile_hierarchies_loaded_total 1\n"), std::string::npos) << metrics->body;
  EXPECT_EQ(b.stop(), 0) << b.output();
}
