// The operator page's mission mode with server-rendered views (?render=server) in a real browser: headless Chromium
// (Debian's) opens /?mission=NAME on the real server while the test posts keyframes (real TUM frames reduced by the
// CLI) one by one, each after the page showed the one before. The page follows the event stream, re-renders after each
// keyframe and counts the drawn pixels of its fixed orbit view; the server ends every event stream after 3 s, so the
// page must reconnect (EventSource, Last-Event-ID) to see the later keyframes. The test asserts the drawn pixels grow,
// every keyframe arrived exactly once despite the reconnects, the trajectory overlay was drawn, the robot-view and
// follow buttons moved the view to the newest keyframe's camera, and the overlay then projects with that keyframe's own
// intrinsics (fr1: fx 517.3), not a fixed 525.
#include <gtest/gtest.h>
#include <httplib.h>
#include <signal.h>
#include <sys/wait.h>

#include <chrono>
#include <cmath>
#include <thread>

#include <nlohmann/json.hpp>

#include "tests/common/test_data.h"
#include "tests/gltf/headless_chromium.h"
#include "tests/gltf/static_http_server.h"
#include "tests/service/mission_keyframes.h"
#include "tests/service/server_process.h"

using nlohmann::json;

TEST(MissionPage, HeadlessChromiumFollowsAGrowingMission) {
  REQUIRE_DATA(rgbdcast::test::kMissionExcerpt);
  const std::string chromium = rgbdcast::test::find_chromium();
  if (chromium.empty()) RGBDCAST_MISSING_PREREQUISITE("no chromium (scripts/setup.sh installs it)");
  std::string error;
  const auto k = rgbdcast::test::mission_keyframes({0, 40, 80, 119}, &error);
  ASSERT_EQ(k.size(), 4u) << error;
  const std::string dir = rgbdcast::test::temp_dir("mission-page");
  rgbdcast::test::ServerProcess server;
  ASSERT_TRUE(server.start(dir + "/data", {"--event-stream-max-s", "3"}, &error)) << error;
  httplib::Client c("127.0.0.1", server.port());
  c.set_read_timeout(120, 0);
  auto post = [&](int seq) {
    const auto& f = k[static_cast<size_t>(seq)];
    const std::string path = "/v1/missions/robot1/keyframes?seq=" + std::to_string(seq) + "&pose=" + f.pose;
    auto r = c.Post(path.c_str(), f.glb, "model/gltf-binary");
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 201) << r->body;
  };
  post(0);

  rgbdcast::test::StaticHttpServer reports(rgbdcast::test::source_path("tools"));
  ASSERT_TRUE(reports.start());
  const std::string url =
      "http://127.0.0.1:" + std::to_string(server.port()) +
      "/?mission=robot1&render=server&selftest=4&report=http://127.0.0.1:" + std::to_string(reports.port()) + "/result";
  const std::string profile = dir + "/profile", log = dir + "/chromium.log";
  std::vector<std::string> args = {chromium,
                                   "--headless",
                                   "--no-sandbox",
                                   "--disable-gpu",
                                   "--no-first-run",
                                   "--disable-background-networking",
                                   "--disable-component-update",
                                   "--disable-sync",
                                   "--hide-scrollbars",
                                   "--user-data-dir=" + profile,
                                   "--window-size=1000,600",
                                   url};
  const pid_t pid = rgbdcast::test::spawn_chromium(args, log, dir);
  ASSERT_GT(pid, 0) << "cannot start " << chromium;

  // Keyframes arrive while the page watches: each once the page has shown the ones before, and 2.5 s later, so that
  // at least one stream end falls between them.
  for (int seq = 1; seq < 4; ++seq) {
    if (!reports.wait_for_post({"/shown-" + std::to_string(seq)}, 60000)) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(2500));
    post(seq);
  }
  const auto posted = reports.wait_for_post({"/result"}, 90000);
  kill(pid, SIGTERM);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(posted) << "the page reported nothing; " << rgbdcast::test::read_file(log).substr(0, 3000);
  const json r = json::parse(posted->second, nullptr, false);
  ASSERT_TRUE(r.is_object() && !r.contains("error")) << posted->second;
  std::cout << "mission page: " << r.dump() << "\n";
  EXPECT_EQ(r["seen"], json({0, 1, 2, 3}));
  EXPECT_EQ(r["distinct"], 4);
  EXPECT_EQ(r["received"], 4) << "a reconnect replayed keyframes the page already had";
  EXPECT_GE(r["reconnects"].get<int>(), 1) << "the stream never dropped: the test did not test reconnecting";
  ASSERT_EQ(r["pixels"].size(), 4u);
  for (size_t i = 1; i < 4; ++i) EXPECT_GE(r["pixels"][i].get<int>(), r["pixels"][i - 1].get<int>()) << r["pixels"];
  EXPECT_GT(r["pixels"][3].get<int>(), r["pixels"][0].get<int>() * 11 / 10) << r["pixels"];
  EXPECT_GT(r["pixels"][0].get<int>(), 1000 * 600 / 50) << "the first view is nearly empty";
  // The orbit view shows the trajectory: more of it as the robot moves.
  ASSERT_EQ(r["overlayPixels"].size(), 4u);
  EXPECT_GT(r["overlayPixels"][3].get<int>(), r["overlayPixels"][0].get<int>()) << r["overlayPixels"];
  EXPECT_NE(r["robotUrl"].get<std::string>().find("pose=keyframe:3"), std::string::npos) << r["robotUrl"];
  EXPECT_NE(r["followUrl"].get<std::string>().find("pose=capture"), std::string::npos) << r["followUrl"];
  // In robot view the overlay projects with keyframe 3's own intrinsics (as listed by the service, scaled to the
  // view's size, the window's, as ViewCamera::from_capture scales them), not with a fixed focal length.
  {
    httplib::Client c("127.0.0.1", server.port());
    auto listed = c.Get("/v1/missions/robot1");
    ASSERT_TRUE(listed && listed->status == 200);
    const json k = json::parse(listed->body)["keyframes"][3]["intrinsics"];
    ASSERT_TRUE(k.is_object()) << listed->body;
    ASSERT_TRUE(r["robotCamera"].is_object()) << r.dump();
    EXPECT_EQ(r["robotCamera"]["width"], 1000);
    const double sx = r["robotCamera"]["width"].get<double>() / k["width"].get<double>();
    const double sy = r["robotCamera"]["height"].get<double>() / k["height"].get<double>();
    EXPECT_NEAR(r["robotCamera"]["fx"].get<double>(), k["fx"].get<double>() * sx, 1e-6) << r["robotCamera"];
    EXPECT_NEAR(r["robotCamera"]["fy"].get<double>(), k["fy"].get<double>() * sy, 1e-6) << r["robotCamera"];
    EXPECT_NEAR(r["robotCamera"]["cx"].get<double>(), (k["cx"].get<double>() + 0.5) * sx - 0.5, 1e-6);
    EXPECT_NEAR(r["robotCamera"]["cy"].get<double>(), (k["cy"].get<double>() + 0.5) * sy - 0.5, 1e-6);
    EXPECT_GT(std::abs(k["fx"].get<double>() - 525.0), 1.0) << "these keyframes' fx is 525 anyway";
  }
  server.stop();
  if (!HasFailure()) rgbdcast::test::remove_tree_quietly(dir);
}
