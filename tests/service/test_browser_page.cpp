// The operator page's local rendering in headless Chromium (Debian's, SwiftShader WebGL) against the real server with
// real keyframes (TUM frames reduced by the CLI): /?mission=NAME draws the mission from its 3D Tiles tileset with
// three.js and 3DTilesRendererJS served by `rgbdcast serve` itself, more of it as keyframes arrive, fetches tiles and
// asks for no server view; resizing the view area redraws at the new size; the page's requests in Chromium's network
// log name no host but the loopback one; /?scene=ID draws that scene's GLB. The same URL in a Chromium without WebGL
// falls back to server-rendered views.
#include <gtest/gtest.h>
#include <httplib.h>
#include <signal.h>
#include <sys/wait.h>

#include <algorithm>
#include <filesystem>
#include <functional>
#include <regex>
#include <sstream>

#include <nlohmann/json.hpp>

#include "tests/common/test_data.h"
#include "tests/gltf/headless_chromium.h"
#include "tests/gltf/static_http_server.h"
#include "tests/service/mission_keyframes.h"
#include "tests/service/server_process.h"

using nlohmann::json;
namespace fs = std::filesystem;

namespace {

struct PageRun {
  json report;
  std::string log, net_log;
};

// Opens `url` (its report= goes to a loopback server of the test) in Chromium with `flags`, calls `meanwhile` with
// that server while the page runs, and returns what the page reported (null when nothing came within 90 s).
PageRun run_page(const std::string& chromium, const std::string& dir, const std::string& tag, int port,
                 const std::string& query, const std::vector<std::string>& flags,
                 const std::function<void(rgbdcast::test::StaticHttpServer&)>& meanwhile) {
  PageRun run;
  rgbdcast::test::StaticHttpServer reports(rgbdcast::test::source_path("tools"));
  if (!reports.start()) return run;
  const std::string url = "http://127.0.0.1:" + std::to_string(port) + "/?" + query +
                          "&report=http://127.0.0.1:" + std::to_string(reports.port()) + "/result";
  run.log = dir + "/" + tag + "-chromium.log";
  run.net_log = dir + "/" + tag + "-netlog.json";
  std::vector<std::string> args = {chromium,
                                   "--headless",
                                   "--no-sandbox",
                                   "--no-first-run",
                                   "--disable-background-networking",
                                   "--disable-component-update",
                                   "--disable-sync",
                                   "--hide-scrollbars",
                                   "--user-data-dir=" + dir + "/profile-" + tag,
                                   "--window-size=960,600",
                                   "--log-net-log=" + run.net_log};
  args.insert(args.end(), flags.begin(), flags.end());
  args.push_back(url);
  const pid_t pid = rgbdcast::test::spawn_chromium(args, run.log, dir);
  if (pid <= 0) return run;
  meanwhile(reports);
  const auto posted = reports.wait_for_post({"/result"}, 90000);
  kill(pid, SIGTERM);
  int status = 0;
  waitpid(pid, &status, 0);
  if (posted) run.report = json::parse(posted->second, nullptr, false);
  return run;
}

// The hosts of the requests Chromium's network log files under the page's site (its network isolation key names the
// top frame's site: every request the page or its modules make, to whatever host). Chromium's own background requests
// (component updates, sign-in checks) carry another key or none and are not the page's. One event per line.
std::vector<std::string> page_request_hosts(const std::string& path) {
  std::vector<std::string> hosts;
  std::istringstream lines(rgbdcast::test::read_file(path));
  static const std::regex kHost(R"(^[a-z]+://([^/:?#]+))");
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("{\"params\"", 0) != 0 || line.find("network_isolation_key") == std::string::npos) continue;
    if (!line.empty() && line.back() == ',') line.pop_back();
    const json e = json::parse(line, nullptr, false);
    if (!e.is_object() || !e["params"].contains("url") || !e["params"]["network_isolation_key"].is_string()) continue;
    if (e["params"]["network_isolation_key"].get<std::string>().rfind("http://127.0.0.1 ", 0) != 0) continue;
    const std::string url = e["params"]["url"].get<std::string>();
    std::smatch m;
    hosts.push_back(std::regex_search(url, m, kHost) ? m[1].str() : url);
  }
  return hosts;
}

class BrowserPage : public ::testing::Test {
 protected:
  void SetUp() override {
    REQUIRE_DATA(rgbdcast::test::kMissionExcerpt);
    chromium_ = rgbdcast::test::find_chromium();
    if (chromium_.empty()) RGBDCAST_MISSING_PREREQUISITE("no chromium (scripts/setup.sh installs it)");
    std::string error;
    keyframes_ = rgbdcast::test::mission_keyframes({0, 40, 80}, &error);
    ASSERT_EQ(keyframes_.size(), 3u) << error;
    dir_ = rgbdcast::test::temp_dir("browser-page");
    ASSERT_TRUE(server_.start(dir_ + "/data", {}, &error)) << error;
  }
  void TearDown() override {
    if (server_.running()) server_.stop();
    if (!HasFailure() && !dir_.empty()) rgbdcast::test::remove_tree_quietly(dir_);
  }
  void post(int i) {
    httplib::Client c("127.0.0.1", server_.port());
    c.set_read_timeout(120, 0);
    const auto& f = keyframes_[static_cast<size_t>(i)];
    const std::string path = "/v1/missions/robot1/keyframes?seq=" + std::to_string(i) + "&pose=" + f.pose;
    auto r = c.Post(path.c_str(), f.glb, "model/gltf-binary");
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 201) << r->body;
  }
  std::string chromium_, dir_;
  std::vector<rgbdcast::test::MissionKeyframeFile> keyframes_;
  rgbdcast::test::ServerProcess server_;
};

TEST_F(BrowserPage, WebGlDrawsTheMissionFromItsTilesAsKeyframesArriveAndASceneFromItsGlb) {
  for (const char* module :
       {"tools/node_modules/three/build/three.module.js", "tools/node_modules/3d-tiles-renderer/build/index.three.js"})
    if (!fs::exists(rgbdcast::test::source_path(module)))
      RGBDCAST_MISSING_PREREQUISITE(std::string(module) + " missing (scripts/setup.sh runs npm ci in tools/)");
  post(0);
  // Keyframes arrive while the page watches: each once the page has drawn the tileset holding the ones before.
  const PageRun run = run_page(chromium_, dir_, "webgl", server_.port(), "mission=robot1&selftest=3",
                               {"--disable-gpu", "--enable-unsafe-swiftshader", "--use-angle=swiftshader"},
                               [&](rgbdcast::test::StaticHttpServer& page) {
                                 for (int i = 1; i < 3; ++i) {
                                   if (!page.wait_for_post({"/drawn-" + std::to_string(i)}, 60000)) return;
                                   post(i);
                                 }
                               });
  const json& r = run.report;
  ASSERT_TRUE(r.is_object() && !r.contains("error")) << r.dump() << "\n"
                                                     << rgbdcast::test::read_file(run.log).substr(0, 3000);
  json shown = r;
  shown["network"].erase("urls");
  std::cout << "page (WebGL): " << shown.dump() << "\n";
  EXPECT_EQ(r["mode"], "local") << r["note"];
  EXPECT_EQ(r["distinct"], 3);
  // The drawn pixels grow as the tileset takes the keyframes.
  const json& s = r["samples"];
  ASSERT_GE(s.size(), 3u) << s;
  EXPECT_EQ(s[0]["keyframes"], 1) << s;
  EXPECT_GT(s[0]["drawn"].get<int>(), 0) << s;
  EXPECT_GT(s.back()["drawn"].get<int>(), s[0]["drawn"].get<int>() * 11 / 10) << s;
  EXPECT_EQ(s.back()["keyframes"], 3) << s;
  // Tiles came over the network; no view was asked of the server.
  const json& n = r["network"];
  EXPECT_GT(n["tileRequests"].get<int>(), 0) << shown;
  EXPECT_GT(n["tileBytes"].get<int>(), 0) << shown;
  EXPECT_EQ(n["viewRequests"], 0) << shown;
  for (const auto& u : n["urls"]) EXPECT_EQ(u.get<std::string>().find("/view?"), std::string::npos) << u;
  // The server's origin, and the test's report server beside it (the page's progress POSTs): loopback only.
  EXPECT_NE(std::find(n["origins"].begin(), n["origins"].end(), "http://127.0.0.1:" + std::to_string(server_.port())),
            n["origins"].end())
      << n["origins"];
  for (const auto& o : n["origins"]) EXPECT_EQ(o.get<std::string>().rfind("http://127.0.0.1:", 0), 0u) << o;
  // Resizing redraws at the new size.
  const json& before = r["resized"]["before"];
  const json& after = r["resized"]["after"];
  EXPECT_EQ(before["width"], 960);
  EXPECT_NEAR(after["width"].get<double>(), 0.6 * 960, 1.0) << r["resized"];
  EXPECT_NEAR(after["height"].get<double>(), 0.7 * before["height"].get<double>(), 1.0) << r["resized"];
  EXPECT_GT(after["drawn"].get<int>(), after["width"].get<int>() * after["height"].get<int>() / 20) << r["resized"];
  // Below the page's own accounting, Chromium's network log: the page asked no other host.
  const auto hosts = page_request_hosts(run.net_log);
  EXPECT_GT(hosts.size(), 10u) << "the page's requests are not in the network log " << run.net_log;
  for (const auto& h : hosts) EXPECT_EQ(h, "127.0.0.1") << run.net_log;

  // A scene's address, /?scene=ID, draws that scene's GLB in the browser too.
  httplib::Client c("127.0.0.1", server_.port());
  c.set_read_timeout(120, 0);
  auto up = c.Post("/v1/scenes", keyframes_[0].glb, "model/gltf-binary");
  ASSERT_TRUE(up);
  ASSERT_EQ(up->status, 201) << up->body;
  const std::string id = json::parse(up->body)["id"];
  const PageRun scene = run_page(chromium_, dir_, "scene", server_.port(), "scene=" + id + "&selftest=1",
                                 {"--disable-gpu", "--enable-unsafe-swiftshader", "--use-angle=swiftshader"},
                                 [](rgbdcast::test::StaticHttpServer&) {});
  const json& sr = scene.report;
  ASSERT_TRUE(sr.is_object() && !sr.contains("error")) << sr.dump() << "\n"
                                                       << rgbdcast::test::read_file(scene.log).substr(0, 3000);
  std::cout << "page (scene, WebGL): drawn " << sr["drawn"] << " of " << sr["width"] << "x" << sr["height"]
            << ", requests " << sr["network"]["urls"].size() << "\n";
  EXPECT_EQ(sr["mode"], "local");
  EXPECT_GT(sr["drawn"].get<int>(), sr["width"].get<int>() * sr["height"].get<int>() / 20) << sr.dump();
  EXPECT_EQ(sr["network"]["viewRequests"], 0);
  bool glb = false;
  for (const auto& u : sr["network"]["urls"])
    glb = glb || u.get<std::string>().find("/v1/scenes/" + id + "/model.glb") != std::string::npos;
  EXPECT_TRUE(glb) << sr["network"]["urls"];
}

TEST_F(BrowserPage, WithoutWebGlTheSameUrlShowsServerViews) {
  for (int i = 0; i < 3; ++i) post(i);
  const PageRun run =
      run_page(chromium_, dir_, "no-webgl", server_.port(), "mission=robot1&selftest=3",
               {"--disable-gpu", "--disable-3d-apis", "--disable-webgl"}, [](rgbdcast::test::StaticHttpServer&) {});
  const json& r = run.report;
  ASSERT_TRUE(r.is_object() && !r.contains("error")) << r.dump() << "\n"
                                                     << rgbdcast::test::read_file(run.log).substr(0, 3000);
  json shown = r;
  shown["network"].erase("urls");
  std::cout << "page (no WebGL): " << shown.dump() << "\n";
  EXPECT_EQ(r["mode"], "server");
  EXPECT_NE(r["note"].get<std::string>().find("WebGL is not available"), std::string::npos) << r["note"];
  EXPECT_GT(r["network"]["viewRequests"].get<int>(), 0);
  EXPECT_EQ(r["network"]["tileRequests"], 0);
  ASSERT_EQ(r["pixels"].size(), 3u);
  EXPECT_GT(r["pixels"][2].get<int>(), 0) << r["pixels"];
  // A late join reads the replayed keyframes once, not once per event, and renders accordingly.
  EXPECT_EQ(r["received"], 3);
  EXPECT_LT(r["syncs"].get<int>(), 3) << shown;
  EXPECT_NE(r["robotUrl"].get<std::string>().find("pose=keyframe:2"), std::string::npos) << r["robotUrl"];
  const auto hosts = page_request_hosts(run.net_log);
  EXPECT_GT(hosts.size(), 5u) << "the page's requests are not in the network log " << run.net_log;
  for (const auto& h : hosts) EXPECT_EQ(h, "127.0.0.1") << run.net_log;
}

}  // namespace
