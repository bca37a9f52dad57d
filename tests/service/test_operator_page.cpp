// The operator page's server-rendered views in a real browser: headless Chromium (Debian's) opens
// GET /?render=server&selftest=1 on the real server, the
// page lists the scene, shows the capture view, orbits once by a scripted drag (30 degrees) and marks itself done;
// the DOM says the last view was an eye/target view and the screenshot of the view region is a rendered image, not
// the page background.
#include <gtest/gtest.h>
#include <httplib.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <regex>

#include "tests/common/test_data.h"
#include "tests/service/server_process.h"

namespace fs = std::filesystem;

namespace {

constexpr const char* kChromium = "/usr/bin/chromium";
constexpr const char* kFr1 = "tum/rgbd_dataset_freiburg1_xyz/rgb/1305031102.175304.png";

// Runs chromium headless with a fresh profile (its temporary files in it too); returns its stdout. Never downloads
// anything.
std::string run_chromium(const std::string& profile, const std::string& mode_args, const std::string& url,
                         int* exit_code) {
  const std::string cmd = "TMPDIR='" + profile + "' " + std::string(kChromium) +
                          " --headless --no-sandbox --disable-gpu --no-first-run --disable-background-networking"
                          " --disable-component-update --disable-sync --disable-dev-shm-usage --hide-scrollbars"
                          " --user-data-dir=" +
                          profile + " --window-size=1000,600 --virtual-time-budget=30000 " + mode_args + " '" + url +
                          "' 2>" + profile + "/stderr.txt";
  std::string out;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return out;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
  const int status = pclose(p);
  *exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return out;
}

}  // namespace

TEST(ServicePage, HeadlessChromiumOrbitsAndShowsARenderedView) {
  REQUIRE_DATA(kFr1);
  if (!fs::exists(kChromium)) {
    if (std::getenv("CI") && std::string(std::getenv("CI")) == "true") FAIL() << "no " << kChromium;
    GTEST_SKIP() << "no " << kChromium << " (scripts/setup.sh installs it)";
  }
  const std::string dir = rgbdcast::test::temp_dir("service-page");
  rgbdcast::test::ServerProcess server;
  std::string error;
  ASSERT_TRUE(server.start(dir + "/data", {}, &error)) << error;
  httplib::Client c("127.0.0.1", server.port());
  c.set_read_timeout(180, 0);
  const auto f = rgbdcast::test::fr1_frame0();
  auto up = c.Post("/v1/scenes", httplib::MultipartFormDataItems{{"color", f.color, "color.png", "image/png"},
                                                                 {"depth", f.depth, "depth.png", "image/png"},
                                                                 {"intrinsics", f.intrinsics_json, "k.json", ""}});
  ASSERT_TRUE(up);
  ASSERT_EQ(up->status, 201) << up->body;
  const std::string id = nlohmann::json::parse(up->body)["id"];

  auto page = c.Get("/");
  ASSERT_TRUE(page);
  ASSERT_EQ(page->status, 200);
  EXPECT_NE(page->get_header_value("Content-Type").find("text/html"), std::string::npos);

  const std::string url = "http://127.0.0.1:" + std::to_string(server.port()) + "/?render=server&selftest=1";
  int code = -1;
  fs::create_directories(dir + "/profile-dom");
  const std::string dom = run_chromium(dir + "/profile-dom", "--dump-dom", url, &code);
  EXPECT_EQ(code, 0) << rgbdcast::test::read_file(dir + "/profile-dom/stderr.txt");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(dom, m, std::regex(R"re(<body[^>]*data-selftest="([a-z-]+)")re")))
      << dom.substr(0, 2000);
  EXPECT_EQ(m[1].str(), "done") << dom.substr(0, 2000);
  ASSERT_TRUE(std::regex_search(dom, m, std::regex(R"re(data-last-view="([^"]+)")re")));
  const std::string last_view = m[1].str();
  EXPECT_NE(last_view.find("/v1/scenes/" + id + "/view?"), std::string::npos) << last_view;
  EXPECT_NE(last_view.find("eye="), std::string::npos) << last_view;
  ASSERT_TRUE(std::regex_search(dom, m, std::regex(R"re(data-views="(\d+)")re")));
  EXPECT_GE(std::stoi(m[1].str()), 2);  // the capture view, then the orbit
  ASSERT_TRUE(std::regex_search(dom, m, std::regex(R"re(<span id="render-ms">([0-9.]+)</span>)re")));
  EXPECT_GT(std::stod(m[1].str()), 0.0);

  fs::create_directories(dir + "/profile-shot");
  const std::string shot = dir + "/page.png";
  run_chromium(dir + "/profile-shot", "--screenshot=" + shot, url, &code);
  EXPECT_EQ(code, 0) << rgbdcast::test::read_file(dir + "/profile-shot/stderr.txt");
  const cv::Mat img = cv::imread(shot, cv::IMREAD_COLOR);
  ASSERT_FALSE(img.empty()) << "no screenshot at " << shot;
  ASSERT_GE(img.cols, 640);
  ASSERT_GE(img.rows, 480);
  // The view fills the window and the scene sits in its middle; the panel covers the top right. The 500x400 of the
  // view left of the panel's edge and above the status line: blank would be the page's #3a4458 background or black.
  const cv::Mat view = img(cv::Rect(150, 100, 500, 400));
  int rendered = 0;
  for (int y = 0; y < view.rows; ++y)
    for (int x = 0; x < view.cols; ++x) {
      const cv::Vec3b p = view.at<cv::Vec3b>(y, x);  // BGR
      const bool box = std::abs(p[0] - 0x58) < 6 && std::abs(p[1] - 0x44) < 6 && std::abs(p[2] - 0x3a) < 6;
      const bool black = p[0] < 10 && p[1] < 10 && p[2] < 10;
      if (!box && !black) ++rendered;
    }
  cv::Scalar mean, sd;
  cv::meanStdDev(view, mean, sd);
  const double fraction = rendered / (500.0 * 400.0);
  std::cout << "screenshot view region: " << fraction * 100 << " % rendered pixels, stddev " << sd[0] << "/" << sd[1]
            << "/" << sd[2] << "\n";
  EXPECT_GT(fraction, 0.2);
  EXPECT_GT(sd[0] + sd[1] + sd[2], 30.0);
  server.stop();
  if (!HasFailure()) rgbdcast::test::remove_tree_quietly(dir);
}
