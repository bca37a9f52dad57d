// The real `rgbdcast serve` driven over loopback HTTP: uploads both ways (GLB and an RGB-D frame of TUM fr1/xyz),
// list, views (decoded and checked), GLB download with ETag, every bad input with its status and JSON
// error body, metrics, concurrency and the bounded queue, restart persistence, kill -9 during uploads.
#include <arpa/inet.h>
#include <httplib.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <thread>

#include "base/stopwatch.h"
#include "tests/common/test_data.h"
#include "tests/service/raw_http.h"
#include "tests/service/server_process.h"

namespace fs = std::filesystem;
using nlohmann::json;
using rgbdcast::test::ServerProcess;

using rgbdcast::ms_since;

namespace {

constexpr const char* kFr1 = "tum/rgbd_dataset_freiburg1_xyz/rgb/1305031102.175304.png";

std::unique_ptr<httplib::Client> client(int port) {
  auto c = std::make_unique<httplib::Client>("127.0.0.1", port);
  c->set_connection_timeout(5, 0);
  c->set_read_timeout(180, 0);  // a frame upload reduces on the server: seconds
  c->set_write_timeout(60, 0);
  return c;
}

// Every error is {"error": "<name>", "detail": "<text>"} with Content-Type application/json.
void expect_json_error(const httplib::Result& r, int status, const std::string& what) {
  ASSERT_TRUE(r) << what << ": no response (" << httplib::to_string(r.error()) << ")";
  EXPECT_EQ(r->status, status) << what << ": " << r->body;
  EXPECT_NE(r->get_header_value("Content-Type").find("application/json"), std::string::npos) << what;
  const json body = json::parse(r->body, nullptr, false);
  ASSERT_TRUE(body.is_object()) << what << ": body is not JSON: " << r->body;
  ASSERT_TRUE(body.contains("error") && body["error"].is_string()) << what << ": " << r->body;
  ASSERT_TRUE(body.contains("detail") && body["detail"].is_string()) << what << ": " << r->body;
  EXPECT_FALSE(body["detail"].get<std::string>().empty()) << what;
}

httplib::MultipartFormDataItems frame_parts(const rgbdcast::test::FrameFiles& f) {
  return {{"color", f.color, "color.png", "image/png"},
          {"depth", f.depth, "depth.png", "image/png"},
          {"intrinsics", f.intrinsics_json, "intrinsics.json", "application/json"}};
}

struct ImageStats {
  double covered = 0.0;  // fraction of pixels not background (any channel > 8)
  double stddev = 0.0;   // of the grey values
};
ImageStats stats_of(const cv::Mat& bgr) {
  cv::Mat grey;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  cv::Mat maxc;
  cv::Mat channels[3];
  cv::split(bgr, channels);
  maxc = cv::max(cv::max(channels[0], channels[1]), channels[2]);
  ImageStats s;
  s.covered = static_cast<double>(cv::countNonZero(maxc > 8)) / static_cast<double>(bgr.total());
  cv::Scalar mean, sd;
  cv::meanStdDev(grey, mean, sd);
  s.stddev = sd[0];
  return s;
}

size_t files_in(const std::string& dir) {
  size_t n = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++n;
  return n;
}

using rgbdcast::test::connect_loopback;
using rgbdcast::test::send_all;

// One server for the suite: starting it and reducing frame 0 on it takes seconds, so the tests share them.
class ServiceHttp : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    std::string why;
    if (!rgbdcast::test::have_data(kFr1, &why)) return;
    data_dir_ = rgbdcast::test::temp_dir("service-http");
    server_ = new ServerProcess();
    std::string error;
    if (!server_->start(data_dir_, {}, &error)) {
      start_error_ = error;
      return;
    }
    auto c = client(server_->port());
    const auto t0 = std::chrono::steady_clock::now();
    auto r = c->Post("/v1/scenes", frame_parts(rgbdcast::test::fr1_frame0()));
    upload_ms_ = ms_since(t0);
    if (!r || r->status != 201) {
      start_error_ =
          "frame upload failed: " + (r ? std::to_string(r->status) + " " + r->body : std::string("no response"));
      return;
    }
    frame_scene_ = json::parse(r->body);
    auto g = c->Get(("/v1/scenes/" + frame_scene_["id"].get<std::string>() + "/model.glb").c_str());
    if (g && g->status == 200) frame_glb_ = g->body;
  }
  static void TearDownTestSuite() {
    if (server_) {
      server_->stop();
      delete server_;
      server_ = nullptr;
    }
    if (!data_dir_.empty()) fs::remove_all(data_dir_);
  }
  void SetUp() override {
    REQUIRE_DATA(kFr1);
    ASSERT_TRUE(start_error_.empty()) << start_error_;
    ASSERT_NE(server_, nullptr);
    c_ = client(server_->port());
  }
  std::string frame_id() const { return frame_scene_["id"].get<std::string>(); }
  size_t scene_count() {
    auto r = c_->Get("/v1/scenes");
    EXPECT_TRUE(r && r->status == 200);
    return r ? json::parse(r->body)["scenes"].size() : 0;
  }

  static inline ServerProcess* server_ = nullptr;
  static inline std::string data_dir_, start_error_, frame_glb_;
  static inline json frame_scene_;
  static inline double upload_ms_ = 0.0;
  std::unique_ptr<httplib::Client> c_;
};

TEST_F(ServiceHttp, FrameUploadIsReducedAndDescribed) {
  const json& s = frame_scene_;
  std::cout << "frame 0 upload (reduce + atlas + GLB on the server): " << upload_ms_ << " ms, " << s["bytes"]
            << " bytes, " << s["triangles"] << " triangles\n";
  EXPECT_TRUE(s["id"].is_string());
  EXPECT_EQ(s["id"].get<std::string>().size(), 32u);
  EXPECT_EQ(s["source"], "frame");
  // The default is the realtime preset under its default budget (min(40 kB, a quarter of the frame's JPEG90+PNG16
  // payload): 40 kB here), as `rgbdcast reduce` with no options: thousands of triangles, at most 20k.
  ASSERT_TRUE(s["reduction"].is_object()) << s;
  EXPECT_EQ(s["reduction"]["preset"], "realtime");
  EXPECT_GT(s["triangles"].get<int>(), 2000);
  EXPECT_LE(s["triangles"].get<int>(), 20000);
  EXPECT_GT(s["bytes"].get<int>(), 10000);
  EXPECT_LE(s["bytes"].get<int>(), 40000 * 11 / 10);
  ASSERT_TRUE(s["capture_camera"].is_object());
  EXPECT_NEAR(s["capture_camera"]["fx"].get<double>(), 517.3, 1e-6);
  EXPECT_EQ(s["capture_camera"]["width"], 640);
  std::set<std::string> stages;
  for (const auto& st : s["stages"]) {
    stages.insert(st["name"].get<std::string>());
    EXPECT_GE(st["ms"].get<double>(), 0.0);
  }
  for (const char* name : {"decode", "filter", "triangulate", "atlas", "budget", "export"})
    EXPECT_TRUE(stages.count(name)) << name << " " << s["stages"];
  EXPECT_FALSE(stages.count("voxel")) << "the paper's stages: " << s["stages"];
  // Bounds: frame 0 of fr1/xyz sees depth between 0.86 and 3.7 m.
  ASSERT_TRUE(s["bounds"].is_object());
  EXPECT_GT(s["bounds"]["min"][2].get<double>(), 0.3);
  EXPECT_LT(s["bounds"]["max"][2].get<double>(), 5.0);

  auto one = c_->Get(("/v1/scenes/" + frame_id()).c_str());
  ASSERT_TRUE(one);
  ASSERT_EQ(one->status, 200);
  const json got = json::parse(one->body);
  EXPECT_EQ(got["triangles"], s["triangles"]);
  EXPECT_EQ(got["links"]["model"], "/v1/scenes/" + frame_id() + "/model.glb");

  auto list = c_->Get("/v1/scenes");
  ASSERT_TRUE(list);
  ASSERT_EQ(list->status, 200);
  bool found = false;
  const json listed = json::parse(list->body);
  for (const auto& e : listed["scenes"]) found |= e["id"] == s["id"];
  EXPECT_TRUE(found);
}

// The paper preset stays one form field away; a budget is a form field too; bad values are 400 and store nothing.
TEST_F(ServiceHttp, FrameUploadTakesAPresetAndABudget) {
  const auto f = rgbdcast::test::fr1_frame0();
  auto upload_with = [&](const std::string& name, const std::string& value) {
    auto parts = frame_parts(f);
    parts.push_back({name, value, "", ""});
    auto r = c_->Post("/v1/scenes", parts);
    EXPECT_TRUE(r && r->status == 201) << name << "=" << value << ": " << (r ? r->body : "no response");
    return r && r->status == 201 ? json::parse(r->body) : json::object();
  };
  const json p = upload_with("preset", "paper");
  ASSERT_TRUE(p.contains("reduction"));
  EXPECT_EQ(p["reduction"]["preset"], "paper");
  std::set<std::string> stages;
  for (const auto& st : p["stages"]) stages.insert(st["name"].get<std::string>());
  for (const char* name : {"valid", "outliers", "voxel", "triangulate", "perimeter"})
    EXPECT_TRUE(stages.count(name)) << name << " " << p["stages"];
  EXPECT_GT(p["triangles"].get<int>(), 20000);  // the paper's mesh of this frame: about 40k triangles

  // budget_kb = 0: no budget, so the mesh keeps its 2-sigma tolerance and the texture its quality: more bytes than
  // the default's 40 kB. (A smaller budget than the default is not met on this frame: at 32 sigma and half the
  // texture resolution it is still 31.5 kB, "over-budget".)
  const json b = upload_with("budget_kb", "0");
  ASSERT_TRUE(b.contains("reduction"));
  EXPECT_EQ(b["reduction"]["preset"], "realtime");
  EXPECT_FALSE(b["reduction"].contains("budget")) << b["reduction"];
  EXPECT_GT(b["bytes"].get<int>(), frame_scene_["bytes"].get<int>());

  const size_t before = scene_count();
  auto parts = frame_parts(f);
  for (const auto& [name, value] : std::vector<std::pair<std::string, std::string>>{
           {"preset", "fast"}, {"budget_kb", "lots"}, {"budget_kb", "-3"}, {"budget_kb", "2"}}) {
    parts = frame_parts(f);
    parts.push_back({name, value, "", ""});
    expect_json_error(c_->Post("/v1/scenes", parts), 400, name + "=" + value);
  }
  parts = frame_parts(f);
  parts.push_back({"preset", "paper", "", ""});
  parts.push_back({"budget_kb", "40", "", ""});
  expect_json_error(c_->Post("/v1/scenes", parts), 400, "a budget with the paper preset");
  EXPECT_EQ(scene_count(), before);
  for (const auto& id : {p["id"].get<std::string>(), b["id"].get<std::string>()})
    c_->Delete(("/v1/scenes/" + id).c_str());
}

TEST_F(ServiceHttp, CaptureViewIsAJpegThatLooksLikeTheFrame) {
  auto r = c_->Get(("/v1/scenes/" + frame_id() + "/view?pose=capture&width=640&height=480&quality=90").c_str());
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(r->get_header_value("Content-Type"), "image/jpeg");
  const double render_ms = std::stod(r->get_header_value("X-Render-Ms"));
  EXPECT_GT(render_ms, 0.0);
  const std::string backend = r->get_header_value("X-Backend");
  EXPECT_TRUE(backend == "vulkan" || backend == "osmesa") << backend;
  const cv::Mat img =
      cv::imdecode(cv::Mat(1, static_cast<int>(r->body.size()), CV_8U, r->body.data()), cv::IMREAD_COLOR);
  ASSERT_FALSE(img.empty());
  EXPECT_EQ(img.cols, 640);
  EXPECT_EQ(img.rows, 480);
  const ImageStats st = stats_of(img);
  std::cout << "capture view: " << backend << " " << render_ms << " ms, covered " << st.covered << ", grey stddev "
            << st.stddev << "\n";
  EXPECT_GT(st.covered, 0.4);  // about 75 % of fr1/xyz frame 0 has depth
  EXPECT_GT(st.stddev, 15.0);

  // At the capture pose the view reproduces the photo where it covers: grey-level correlation over covered pixels.
  const cv::Mat photo = cv::imread(rgbdcast::test::data_path(kFr1), cv::IMREAD_COLOR);
  ASSERT_FALSE(photo.empty());
  cv::Mat a, b;
  cv::cvtColor(img, a, cv::COLOR_BGR2GRAY);
  cv::cvtColor(photo, b, cv::COLOR_BGR2GRAY);
  double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0, n = 0;
  for (int y = 0; y < a.rows; ++y)
    for (int x = 0; x < a.cols; ++x) {
      const double va = a.at<uchar>(y, x), vb = b.at<uchar>(y, x);
      if (va <= 8) continue;
      sa += va;
      sb += vb;
      saa += va * va;
      sbb += vb * vb;
      sab += va * vb;
      n += 1;
    }
  const double corr = (sab - sa * sb / n) / std::sqrt((saa - sa * sa / n) * (sbb - sb * sb / n));
  std::cout << "capture view vs photo: correlation " << corr << " over " << n << " pixels\n";
  EXPECT_GT(corr, 0.5);
}

TEST_F(ServiceHttp, OrbitPointsAndPngViews) {
  // Half a metre to the side of the capture camera, looking at the scene's centre.
  const json& b = frame_scene_["bounds"];
  const double cx = 0.5 * (b["min"][0].get<double>() + b["max"][0].get<double>());
  const double cy = 0.5 * (b["min"][1].get<double>() + b["max"][1].get<double>());
  const double cz = 0.5 * (b["min"][2].get<double>() + b["max"][2].get<double>());
  char q[256];
  std::snprintf(q, sizeof q, "eye=0.5,0,0&target=%.4f,%.4f,%.4f&up=0,-1,0&fov=55&width=320&height=240", cx, cy, cz);
  for (const std::string extra : {"&mode=mesh", "&mode=points&point_size=3", "&format=png"}) {
    auto r = c_->Get(("/v1/scenes/" + frame_id() + "/view?" + q + extra).c_str());
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 200) << extra << ": " << r->body;
    const cv::Mat img =
        cv::imdecode(cv::Mat(1, static_cast<int>(r->body.size()), CV_8U, r->body.data()), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(img.empty()) << extra;
    EXPECT_EQ(img.cols, 320);
    EXPECT_EQ(img.rows, 240);
    if (extra == "&format=png") {
      EXPECT_EQ(r->get_header_value("Content-Type"), "image/png");
      EXPECT_EQ(img.channels(), 4);  // alpha: 0 on background
    }
    cv::Mat bgr;
    if (img.channels() == 4)
      cv::cvtColor(img, bgr, cv::COLOR_BGRA2BGR);
    else
      bgr = img;
    const ImageStats st = stats_of(bgr);
    std::cout << "orbit view" << extra << ": covered " << st.covered << ", stddev " << st.stddev << ", render "
              << r->get_header_value("X-Render-Ms") << " ms\n";
    EXPECT_GT(st.covered, 0.2) << extra;
    EXPECT_GT(st.stddev, 10.0) << extra;
  }
}

TEST_F(ServiceHttp, GlbDownloadEqualsTheStoredFileWithEtag) {
  auto r = c_->Get(("/v1/scenes/" + frame_id() + "/model.glb").c_str());
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200);
  EXPECT_EQ(r->get_header_value("Content-Type"), "model/gltf-binary");
  EXPECT_EQ(r->get_header_value("Content-Length"), std::to_string(r->body.size()));
  const std::string stored = rgbdcast::test::read_file(data_dir_ + "/scenes/" + frame_id() + ".glb");
  ASSERT_FALSE(stored.empty());
  EXPECT_TRUE(r->body == stored) << "download differs from the stored file";
  EXPECT_EQ(r->body.substr(0, 4), "glTF");
  const std::string etag = r->get_header_value("ETag");
  ASSERT_FALSE(etag.empty());
  EXPECT_EQ(etag, frame_scene_["etag"].get<std::string>());
  auto again = c_->Get(("/v1/scenes/" + frame_id() + "/model.glb").c_str(), {{"If-None-Match", etag}});
  ASSERT_TRUE(again);
  EXPECT_EQ(again->status, 304);
  EXPECT_TRUE(again->body.empty());
  auto other = c_->Get(("/v1/scenes/" + frame_id() + "/model.glb").c_str(), {{"If-None-Match", "\"nope\""}});
  ASSERT_TRUE(other);
  EXPECT_EQ(other->status, 200);
}

TEST_F(ServiceHttp, GlbUploadListViewAndDelete) {
  ASSERT_FALSE(frame_glb_.empty());
  const size_t before = scene_count();
  // The robot's set-up: it reduced on board and sends the GLB (here: the one the server made from frame 0).
  auto r = c_->Post("/v1/scenes", frame_glb_, "model/gltf-binary");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 201) << r->body;
  const json s = json::parse(r->body);
  const std::string id = s["id"];
  EXPECT_NE(id, frame_id());
  EXPECT_EQ(s["source"], "glb");
  EXPECT_EQ(s["triangles"], frame_scene_["triangles"]);
  EXPECT_EQ(s["bytes"].get<size_t>(), frame_glb_.size());
  EXPECT_EQ(r->get_header_value("Location"), "/v1/scenes/" + id);
  EXPECT_EQ(scene_count(), before + 1);
  auto v = c_->Get(("/v1/scenes/" + id + "/view?pose=capture&width=160&height=120").c_str());
  ASSERT_TRUE(v);
  EXPECT_EQ(v->status, 200);

  auto d = c_->Delete(("/v1/scenes/" + id).c_str());
  ASSERT_TRUE(d);
  EXPECT_EQ(d->status, 204);
  EXPECT_EQ(scene_count(), before);
  EXPECT_FALSE(fs::exists(data_dir_ + "/scenes/" + id + ".glb"));
  EXPECT_FALSE(fs::exists(data_dir_ + "/scenes/" + id + ".json"));
  expect_json_error(c_->Get(("/v1/scenes/" + id).c_str()), 404, "deleted scene");
  expect_json_error(c_->Get(("/v1/scenes/" + id + "/view?pose=capture").c_str()), 404, "view of a deleted scene");
  expect_json_error(c_->Delete(("/v1/scenes/" + id).c_str()), 404, "second delete");
}

TEST_F(ServiceHttp, BadViewQueriesAre400) {
  const std::string base = "/v1/scenes/" + frame_id() + "/view";
  for (const std::string q : {"",
                              "?width=100",
                              "?pose=robot",
                              "?eye=1,2&target=0,0,1",
                              "?eye=a,b,c&target=0,0,1",
                              "?eye=0,0,0",
                              "?target=0,0,1",
                              "?eye=nan,0,0&target=0,0,1",
                              "?eye=0,0,0&target=0,inf,1",
                              "?eye=0,0,0&target=0,0,-inf",
                              "?eye=0,0,0&target=0,0,1&fov=NaN",
                              "?pose=capture&width=0",
                              "?pose=capture&width=5000",
                              "?pose=capture&height=4097",
                              "?pose=capture&height=-3",
                              "?pose=capture&width=abc",
                              "?pose=capture&quality=0",
                              "?pose=capture&mode=wire",
                              "?pose=capture&format=gif",
                              "?pose=capture&zoom=2",
                              "?pose=capture&width=1&width=2",
                              "?eye=1,1,1&target=1,1,1",
                              "?eye=0,0,0&target=0,1,0"})
    expect_json_error(c_->Get((base + q).c_str()), 400, "view" + q);
}

TEST_F(ServiceHttp, UnknownScenesAndPathTraversal) {
  const std::string unknown = "0123456789abcdef0123456789abcdef";
  expect_json_error(c_->Get(("/v1/scenes/" + unknown).c_str()), 404, "unknown scene");
  expect_json_error(c_->Get(("/v1/scenes/" + unknown + "/model.glb").c_str()), 404, "unknown glb");
  expect_json_error(c_->Get(("/v1/scenes/" + unknown + "/view?pose=capture").c_str()), 404, "unknown view");
  expect_json_error(c_->Delete(("/v1/scenes/" + unknown).c_str()), 404, "unknown delete");
  expect_json_error(c_->Get("/v1/nothing"), 404, "unknown route");
  // Ids that try to leave the store: malformed ids are 400, paths that no route matches are 404; never a file.
  for (const std::string& path : std::vector<std::string>{
           "/v1/scenes/..%2F..%2Fetc%2Fpasswd", "/v1/scenes/%2e%2e/model.glb", "/v1/scenes/..%2f" + frame_id(),
           "/v1/scenes/" + frame_id() + "%00", "/v1/scenes/" + frame_id() + "x/view?pose=capture",
           "/v1/scenes/ABCDEF0123456789ABCDEF0123456789", "/v1/scenes/../../etc/passwd",
           "/v1/scenes/%2e%2e%2f%2e%2e%2fetc%2fpasswd/model.glb", "/v1/scenes/.%2e/.%2e/scenes/model.glb"}) {
    auto r = c_->Get(path.c_str());
    ASSERT_TRUE(r) << path;
    EXPECT_TRUE(r->status == 400 || r->status == 404) << path << " -> " << r->status;
    expect_json_error(r, r->status, path);
    EXPECT_EQ(r->body.find("root:"), std::string::npos) << path;
  }
  for (const std::string& path :
       std::vector<std::string>{"/v1/scenes/..%2F..%2Ftmp", "/v1/scenes/..", "/v1/scenes/.%2e"}) {
    auto d = c_->Delete(path.c_str());
    ASSERT_TRUE(d) << path;
    EXPECT_TRUE(d->status == 400 || d->status == 404) << path << " -> " << d->status;
    expect_json_error(d, d->status, "delete " + path);
  }
}

// The page's npm modules: gzipped for a client that accepts gzip (whatever else it accepts), as they are for the
// others, the same bytes as the file either way; only the modules' folders; the page's own files by name.
TEST_F(ServiceHttp, PageModulesAreTheFilesGzippedOnlyUnderTheirFolders) {
  const std::string file = rgbdcast::test::source_path("tools/node_modules/three/build/three.module.js");
  if (!fs::exists(file)) RGBDCAST_MISSING_PREREQUISITE(file + " missing (scripts/setup.sh runs npm ci in tools/)");
  const std::string bytes = rgbdcast::test::read_file(file);
  auto get = [&](const std::string& path, const std::string& accept) {
    return rgbdcast::test::raw_request(
        server_->port(), "GET " + path + " HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(server_->port()) + "\r\n" +
                             accept + "Connection: close\r\n\r\n");
  };
  const auto gz = get("/web/modules/three/build/three.module.js", "Accept-Encoding: gzip, deflate, br, zstd\r\n");
  ASSERT_TRUE(gz.ok);
  EXPECT_EQ(gz.status, 200);
  EXPECT_EQ(gz.headers.count("content-encoding") ? gz.headers.at("content-encoding") : "", "gzip");
  EXPECT_LT(gz.body.size(), bytes.size() / 3);
  EXPECT_TRUE(rgbdcast::test::gunzip(gz.body) == bytes) << "the gzipped module is not the file";
  for (const std::string& accept : {std::string("Accept-Encoding: br\r\n"), std::string()}) {
    const auto plain = get("/web/modules/three/build/three.module.js", accept);
    ASSERT_TRUE(plain.ok) << accept;
    EXPECT_EQ(plain.status, 200) << accept;
    EXPECT_EQ(plain.headers.count("content-encoding"), 0u) << accept;
    EXPECT_TRUE(plain.body == bytes) << accept << ": " << plain.body.size() << " bytes, the file has " << bytes.size();
  }
  expect_json_error(c_->Get("/web/modules/three/package.json"), 404, "a file outside the modules' folders");
  expect_json_error(c_->Get("/web/modules/three/build/..%2F..%2Fpackage.json"), 400, "an escaping path");
  expect_json_error(c_->Get("/web/modules/three/build/.hidden.js"), 400, "a hidden name");
  expect_json_error(c_->Get("/page/nothing.js"), 404, "an unknown page file");
  auto app = c_->Get("/page/app.js");
  ASSERT_TRUE(app);
  EXPECT_EQ(app->status, 200);
  EXPECT_NE(app->get_header_value("Content-Type").find("text/javascript"), std::string::npos);
}

TEST_F(ServiceHttp, BadUploadsStoreNothing) {
  ASSERT_FALSE(frame_glb_.empty());
  const size_t before = scene_count();
  const size_t files_before = files_in(data_dir_ + "/scenes");
  // GLBs: truncated, garbage, empty, a header that lies about its length.
  expect_json_error(c_->Post("/v1/scenes", frame_glb_.substr(0, frame_glb_.size() / 2), "model/gltf-binary"), 422,
                    "truncated GLB");
  expect_json_error(c_->Post("/v1/scenes", frame_glb_.substr(0, 20), "model/gltf-binary"), 422, "GLB header only");
  expect_json_error(c_->Post("/v1/scenes", std::string(5000, 'x'), "model/gltf-binary"), 422, "not a GLB");
  expect_json_error(c_->Post("/v1/scenes", std::string(), "model/gltf-binary"), 422, "empty GLB");
  std::string lying = frame_glb_;
  lying[8] = '\xff';  // total length field
  expect_json_error(c_->Post("/v1/scenes", lying, "model/gltf-binary"), 422, "GLB with a wrong length");
  expect_json_error(c_->Post("/v1/scenes", frame_glb_, "text/plain"), 415, "wrong content type");

  // Frames: colour not an image, depth 8-bit, depth not an image, missing part, bad intrinsics, size mismatch.
  const auto f = rgbdcast::test::fr1_frame0();
  auto parts = frame_parts(f);
  parts[0].content = "this is not a PNG at all";
  expect_json_error(c_->Post("/v1/scenes", parts), 422, "colour not a PNG");
  parts = frame_parts(f);
  {
    cv::Mat depth16 = cv::imdecode(
        cv::Mat(1, static_cast<int>(f.depth.size()), CV_8U, const_cast<char*>(f.depth.data())), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(depth16.type(), CV_16UC1);
    cv::Mat depth8;
    depth16.convertTo(depth8, CV_8U, 1.0 / 256);
    std::vector<uchar> png;
    cv::imencode(".png", depth8, png);
    parts[1].content.assign(png.begin(), png.end());
  }
  expect_json_error(c_->Post("/v1/scenes", parts), 422, "depth 8-bit");
  parts = frame_parts(f);
  parts[1].content = f.depth.substr(0, f.depth.size() / 3);
  expect_json_error(c_->Post("/v1/scenes", parts), 422, "depth PNG truncated");
  parts = frame_parts(f);
  parts[1].content = f.color;  // an 8-bit RGB PNG as depth
  expect_json_error(c_->Post("/v1/scenes", parts), 422, "colour as depth");
  parts = frame_parts(f);
  parts[2].content = "{\"fx\": ";
  expect_json_error(c_->Post("/v1/scenes", parts), 422, "intrinsics not JSON");
  parts = frame_parts(f);
  parts.pop_back();
  expect_json_error(c_->Post("/v1/scenes", parts), 400, "missing intrinsics part");

  EXPECT_EQ(scene_count(), before);
  EXPECT_EQ(files_in(data_dir_ + "/scenes"), files_before);
}

TEST_F(ServiceHttp, BodyOverTheLimitIs413) {
  const size_t before = scene_count();
  const std::string big((64u << 20) + 1, 'g');  // the default limit is 64 MiB
  expect_json_error(c_->Post("/v1/scenes", big, "model/gltf-binary"), 413, "65 MiB body");
  EXPECT_EQ(scene_count(), before);
}

TEST_F(ServiceHttp, HealthAndMetrics) {
  auto h = c_->Get("/healthz");
  ASSERT_TRUE(h);
  EXPECT_EQ(h->status, 200);
  const json hj = json::parse(h->body);
  EXPECT_EQ(hj["status"], "ok");
  ASSERT_TRUE(c_->Get(("/v1/scenes/" + frame_id() + "/view?pose=capture&width=64&height=48").c_str()));
  ASSERT_TRUE(c_->Get(("/v1/scenes/" + frame_id() + "/view?width=0&pose=capture").c_str()));
  // httplib counts a request (its logger) after the response is sent, on the server's thread: a /metrics on a new
  // connection can overtake either view under load (the 200's was late in a clean-clone CI run beside a sanitized
  // build), so wait up to 2 s for both to be counted.
  auto m = c_->Get("/metrics");
  auto both_counted = [](const std::string& body) {
    return body.find("route=\"/v1/scenes/{id}/view\",status=\"400\"") != std::string::npos &&
           body.find("route=\"/v1/scenes/{id}/view\",status=\"200\"") != std::string::npos;
  };
  for (int i = 0; i < 20 && m && !both_counted(m->body); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    m = c_->Get("/metrics");
  }
  ASSERT_TRUE(m);
  ASSERT_EQ(m->status, 200);
  EXPECT_NE(m->get_header_value("Content-Type").find("text/plain"), std::string::npos);
  const std::string& t = m->body;
  for (const std::string& needle : std::vector<std::string>{
           "rgbdcast_http_requests_total{method=\"GET\",route=\"/v1/scenes/{id}/view\",status=\"200\"} ",
           "rgbdcast_http_requests_total{method=\"GET\",route=\"/v1/scenes/{id}/view\",status=\"400\"} ",
           "rgbdcast_http_requests_total{method=\"POST\",route=\"/v1/scenes\",status=\"201\"} ",
           "rgbdcast_http_request_duration_seconds_bucket{route=\"/v1/scenes/{id}/view\",le=\"+Inf\"} ",
           "rgbdcast_render_duration_seconds_count{mode=\"mesh\",backend=\"" + hj["backend"].get<std::string>() +
               "\"} ",
           "rgbdcast_scenes_stored ", "rgbdcast_scenes_stored_bytes "})
    EXPECT_NE(t.find(needle), std::string::npos) << needle << "\n" << t;
  // Gauges agree with the store.
  const size_t pos = t.find("\nrgbdcast_scenes_stored ");
  ASSERT_NE(pos, std::string::npos);
  EXPECT_EQ(std::stoul(t.substr(pos + 24)), scene_count());
}

// Many clients at once: all succeed, and the same view is the same image every time.
TEST_F(ServiceHttp, ConcurrentViewsAreSafeAndDeterministic) {
  const std::string path = "/v1/scenes/" + frame_id() + "/view?pose=capture&width=320&height=240&format=png";
  auto ref = c_->Get(path.c_str());
  ASSERT_TRUE(ref);
  ASSERT_EQ(ref->status, 200);
  std::atomic<int> ok{0}, same{0}, other{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < 6; ++t)
    threads.emplace_back([&] {
      auto c = client(server_->port());
      for (int i = 0; i < 4; ++i) {
        auto r = c->Get(path.c_str());
        if (r && r->status == 200) {
          ++ok;
          if (r->body == ref->body) ++same;
        } else {
          ++other;
        }
      }
    });
  for (auto& th : threads) th.join();
  EXPECT_EQ(ok, 24);
  EXPECT_EQ(same, 24);
  EXPECT_EQ(other, 0);
}

// --import stores a GLB at start, once: a second start with the same file finds it stored.
TEST_F(ServiceHttp, ImportAtStartIsIdempotent) {
  ASSERT_FALSE(frame_glb_.empty());
  const std::string dir = rgbdcast::test::temp_dir("service-import");
  { std::ofstream(dir + "/frame0.glb", std::ios::binary) << frame_glb_; }
  std::string first_id;
  for (int run = 0; run < 2; ++run) {
    ServerProcess server;
    std::string error;
    ASSERT_TRUE(server.start(dir + "/store", {"--import", dir + "/frame0.glb"}, &error)) << error;
    std::smatch m;
    ASSERT_TRUE(std::regex_search(server.output(), m, std::regex("frame0\\.glb is scene ([0-9a-f]{32})")))
        << server.output();
    if (run == 0) first_id = m[1].str();
    EXPECT_EQ(m[1].str(), first_id);
    auto c = client(server.port());
    auto list = c->Get("/v1/scenes");
    ASSERT_TRUE(list);
    EXPECT_EQ(json::parse(list->body)["scenes"].size(), 1u);
    server.stop();
  }
  fs::remove_all(dir);
}

// With no room to wait (--render-queue 0) a view that finds the renderer busy is refused at once: 503, Retry-After.
TEST(ServiceHttpQueue, FullRenderQueueAnswers503) {
  REQUIRE_DATA(kFr1);
  const std::string dir = rgbdcast::test::temp_dir("service-queue");
  ServerProcess server;
  std::string error;
  ASSERT_TRUE(server.start(dir, {"--render-queue", "0", "--renderers", "1"}, &error)) << error;
  auto c = client(server.port());
  auto up = c->Post("/v1/scenes", frame_parts(rgbdcast::test::fr1_frame0()));
  ASSERT_TRUE(up);
  ASSERT_EQ(up->status, 201) << up->body;
  const std::string id = json::parse(up->body)["id"];
  // Large views keep the renderer busy long enough for the others to find it so.
  const std::string path = "/v1/scenes/" + id + "/view?pose=capture&width=4096&height=3072&mode=points&format=jpeg";
  std::atomic<int> ok{0}, busy{0}, other{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < 8; ++t)
    threads.emplace_back([&] {
      auto cc = client(server.port());
      auto r = cc->Get(path.c_str());
      if (r && r->status == 200) {
        ++ok;
      } else if (r && r->status == 503) {
        ++busy;
        EXPECT_EQ(r->get_header_value("Retry-After"), "1");
        expect_json_error(r, 503, "busy");
      } else {
        ++other;
      }
    });
  for (auto& th : threads) th.join();
  std::cout << "8 simultaneous 4096x3072 views with no queue: " << ok << " rendered, " << busy << " refused\n";
  EXPECT_GE(ok, 1);
  EXPECT_GE(busy, 1);
  EXPECT_EQ(other, 0);
  auto m = c->Get("/metrics");
  ASSERT_TRUE(m);
  EXPECT_NE(m->body.find("rgbdcast_render_rejected_total " + std::to_string(busy.load())), std::string::npos);
  server.stop();
  fs::remove_all(dir);
}

TEST(ServiceHttpRestart, ScenesSurviveARestart) {
  REQUIRE_DATA(kFr1);
  const std::string dir = rgbdcast::test::temp_dir("service-restart");
  std::string id, glb, error;
  {
    ServerProcess server;
    ASSERT_TRUE(server.start(dir, {}, &error)) << error;
    auto c = client(server.port());
    auto up = c->Post("/v1/scenes", frame_parts(rgbdcast::test::fr1_frame0()));
    ASSERT_TRUE(up);
    ASSERT_EQ(up->status, 201) << up->body;
    id = json::parse(up->body)["id"];
    auto g = c->Get(("/v1/scenes/" + id + "/model.glb").c_str());
    ASSERT_TRUE(g);
    glb = g->body;
    const int status = server.stop();
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "SIGTERM should stop the server cleanly";
  }
  ServerProcess server;
  ASSERT_TRUE(server.start(dir, {}, &error)) << error;
  EXPECT_NE(server.output().find("1 scenes in"), std::string::npos) << server.output();
  auto c = client(server.port());
  auto list = c->Get("/v1/scenes");
  ASSERT_TRUE(list);
  const json l = json::parse(list->body);
  ASSERT_EQ(l["scenes"].size(), 1u);
  EXPECT_EQ(l["scenes"][0]["id"], id);
  auto g = c->Get(("/v1/scenes/" + id + "/model.glb").c_str());
  ASSERT_TRUE(g);
  EXPECT_TRUE(g->body == glb);
  auto v = c->Get(("/v1/scenes/" + id + "/view?pose=capture&width=200&height=150").c_str());
  ASSERT_TRUE(v);
  EXPECT_EQ(v->status, 200);
  server.stop();
  fs::remove_all(dir);
}

// kill -9 while a large GLB is still arriving, and again while the server reduces an uploaded frame: after a
// restart the store lists nothing and holds no file.
TEST(ServiceHttpRestart, KillDuringUploadLeavesNoHalfScene) {
  REQUIRE_DATA(kFr1);
  const std::string dir = rgbdcast::test::temp_dir("service-kill");
  std::string error;
  size_t acknowledged = 0;
  {
    ServerProcess server;
    ASSERT_TRUE(server.start(dir, {}, &error)) << error;
    const int fd = connect_loopback(server.port());
    ASSERT_GE(fd, 0);
    const size_t total = 40u << 20;
    ASSERT_TRUE(send_all(fd,
                         "POST /v1/scenes HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: model/gltf-binary\r\n"
                         "Content-Length: " +
                             std::to_string(total) + "\r\n\r\n"));
    std::string chunk(1u << 20, 'g');
    memcpy(chunk.data(), "glTF", 4);
    for (int i = 0; i < 12; ++i) {  // 12 of 40 MiB, slowly
      ASSERT_TRUE(send_all(fd, chunk));
      std::this_thread::sleep_for(std::chrono::milliseconds(25));
    }
    server.kill9();
    close(fd);
  }
  {
    ServerProcess server;
    ASSERT_TRUE(server.start(dir, {}, &error)) << error;
    // A whole frame upload; the server is killed while it reduces it (the paper preset: seconds; the default
    // realtime preset would often be done within the 700 ms). Should the reduction ever finish first, the scene is
    // whole and answered 201: the check below counts what was acknowledged.
    const auto f = rgbdcast::test::fr1_frame0();
    std::thread uploader([&] {
      auto cc = client(server.port());
      auto parts = frame_parts(f);
      parts.push_back({"preset", "paper", "", ""});
      auto r = cc->Post("/v1/scenes", parts);
      if (r && r->status == 201) acknowledged = 1;
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(700));
    server.kill9();
    uploader.join();
    std::cout << "kill -9 during frame reduction: upload " << (acknowledged ? "had finished" : "was cut") << "\n";
  }
  ServerProcess server;
  ASSERT_TRUE(server.start(dir, {}, &error)) << error;
  auto c = client(server.port());
  auto list = c->Get("/v1/scenes");
  ASSERT_TRUE(list);
  EXPECT_EQ(json::parse(list->body)["scenes"].size(), acknowledged) << list->body;
  EXPECT_EQ(files_in(dir + "/scenes"), 2 * acknowledged);  // a GLB and its metadata per scene, nothing else
  server.stop();
  fs::remove_all(dir);
}

}  // namespace
