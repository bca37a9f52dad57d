// The operator page's local rendering in headless Chromium (Debian's, SwiftShader WebGL) against the real server with
// real keyframes (TUM frames reduced by the CLI): /?mission=NAME draws the mission from its 3D Tiles tileset with
// three.js and 3DTilesRendererJS served by `rgbdcast serve` itself, more of it as keyframes arrive, fetches tiles and
// asks for no server view; resizing the view area redraws at the new size; Chromium's network log names no host but
// the loopback one. The same URL in a Chromium without WebGL falls back to server-rendered views.
#include <gtest/gtest.h>
#include <httplib.h>
#include <signal.h>
#include <sys/wait.h>

#include <chrono>
#include <filesystem>
#include <regex>
#include <set>
#include <thread>

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

// Opens `url` (its report= goes to a loopback server of the test) in Chromium with `flags`, calls `meanwhile` while
// the page runs, and returns what the page reported (null when nothing came within 90 s).
PageRun run_page(const std::string& chromium, const std::string& dir, const std::string& tag, int port,
                 const std::string& query, const std::vector<std::string>& flags,
                 const std::function<void()>& meanwhile) {
  PageRun run;
  rgbdcast::test::StaticHttpServer reports(rgbdcast::test::source_path("tools"));
  if (!reports.start()) return run;
  const std::string url = "http://127.0.0.1:" + std::to_string(port) + "/?" + query +
                          "&report=http://127.0.0.1:" + std::to_string(reports.port()) + "/result";
  run.log = dir + "/" + tag + "-chromium.log";
  run.net_log = dir + "/" + tag + "-netlog.json";
  std::vector<std::string> args = {chromium, "--headless", "--no-sandbox", "--no-first-run",
                                   "--disable-background-networking", "--disable-component-update", "--disable-sync",
                                   "--hide-scrollbars", "--user-data-dir=" + dir + "/profile-" + tag,
                                   "--window-size=960,600", "--log-net-log=" + run.net_log};
  args.insert(args.end(), flags.begin(), flags.end());
  args.push_back(url);
  const pid_t pid = rgbdcast::test::spawn_chromium(args, run.log, dir);
  if (pid <= 0) return run;
  meanwhile();
  const auto posted = reports.wait_for_post({"/result"}, 90000);
  kill(pid, SIGTERM);
  int status = 0;
  waitpid(pid, &status, 0);
  if (posted) run.report = json::parse(posted->second, nullptr, false);
  return run;
}

// The hosts of every http(s) URL in Chromium's network log.
std::set<std::string> net_log_hosts(const std::string& path) {
  const std::string text = rgbdcast::test::read_file(path);
  std::set<std::string> hosts;
  static const std::regex kUrl(R"(\b(?:https?|wss?)://([^/:"\\]+))");
  for (auto it = std::sregex_iterator(text.begin(), text.end(), kUrl); it != std::sregex_iterator(); ++it)
    hosts.insert((*it)[1].str());
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

TEST_F(BrowserPage, WebGlDrawsTheMissionFromItsTilesAsKeyframesArrive) {
  for (const char* module : {"tools/node_modules/three/build/three.module.js",
                             "tools/node_modules/3d-tiles-renderer/build/index.three.js"})
    if (!fs::exists(rgbdcast::test::source_path(module)))
      RGBDCAST_MISSING_PREREQUISITE(std::string(module) + " missing (scripts/setup.sh runs npm ci in tools/)");
  post(0);
  // Keyframes arrive while the page watches, 4 s apart: the tile worker commits a version between them.
  const PageRun run = run_page(chromium_, dir_, "webgl", server_.port(), "mission=robot1&selftest=3",
                               {"--disable-gpu", "--enable-unsafe-swiftshader", "--use-angle=swiftshader"}, [&] {
                                 for (int i = 1; i < 3; ++i) {
                                   std::this_thread::sleep_for(std::chrono::seconds(4));
                                   post(i);
                                 }
                               });
  const json& r = run.report;
  ASSERT_TRUE(r.is_object() && !r.contains("error"))
      << r.dump() << "\n" << rgbdcast::test::read_file(run.log).substr(0, 3000);
  json shown = r;
  shown["network"].erase("urls");
  std::cout << "page (WebGL): " << shown.dump() << "\n";
  EXPECT_EQ(r["mode"], "local") << r["note"];
  EXPECT_EQ(r["distinct"], 3);
  // The drawn pixels grow as the tileset takes the keyframes.
  const json& s = r["samples"];
  ASSERT_GE(s.size(), 2u) << s;
  EXPECT_GT(s[0]["drawn"].get<int>(), 0) << s;
  EXPECT_GT(s.back()["drawn"].get<int>(), s[0]["drawn"].get<int>() * 11 / 10) << s;
  EXPECT_EQ(s.back()["keyframes"], 3) << s;
  // Tiles came over the network; no view was asked of the server.
  const json& n = r["network"];
  EXPECT_GT(n["tileRequests"].get<int>(), 0) << shown;
  EXPECT_GT(n["tileBytes"].get<int>(), 0) << shown;
  EXPECT_EQ(n["viewRequests"], 0) << shown;
  for (const auto& u : n["urls"]) EXPECT_EQ(u.get<std::string>().find("/view?"), std::string::npos) << u;
  EXPECT_EQ(n["origins"], json::array({"http://127.0.0.1:" + std::to_string(server_.port())})) << n["origins"];
  // Resizing redraws at the new size.
  const json& before = r["resized"]["before"];
  const json& after = r["resized"]["after"];
  EXPECT_EQ(before["width"], 960);
  EXPECT_NEAR(after["width"].get<double>(), 0.6 * 960, 1.0) << r["resized"];
  EXPECT_NEAR(after["height"].get<double>(), 0.7 * before["height"].get<double>(), 1.0) << r["resized"];
  EXPECT_GT(after["drawn"].get<int>(), after["width"].get<int>() * after["height"].get<int>() / 20) << r["resized"];
  // Chromium itself went to no other host.
  const auto hosts = net_log_hosts(run.net_log);
  EXPECT_FALSE(hosts.empty()) << "no URL in the network log " << run.net_log;
  for (const auto& h : hosts) EXPECT_EQ(h, "127.0.0.1") << run.net_log;
}

TEST_F(BrowserPage, WithoutWebGlTheSameUrlShowsServerViews) {
  for (int i = 0; i < 3; ++i) post(i);
  const PageRun run = run_page(chromium_, dir_, "no-webgl", server_.port(), "mission=robot1&selftest=3",
                               {"--disable-gpu", "--disable-3d-apis", "--disable-webgl"}, [] {});
  const json& r = run.report;
  ASSERT_TRUE(r.is_object() && !r.contains("error"))
      << r.dump() << "\n" << rgbdcast::test::read_file(run.log).substr(0, 3000);
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
  for (const auto& h : net_log_hosts(run.net_log)) EXPECT_EQ(h, "127.0.0.1") << run.net_log;
}

}  // namespace
