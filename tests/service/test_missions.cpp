// Live missions against the real `rgbdcast serve`: keyframe GLBs reduced from real TUM fr1/xyz frames by
// the real CLI, posted with their ground-truth poses. Idempotent re-posts and 409 conflicts, the JSON shapes of the
// wire contract, views that grow as keyframes arrive without the mission being uploaded again, the merged model.glb
// (validator-clean, a node and a camera per keyframe), a restart mid-mission (nothing lost or duplicated), a corrupt
// keyframe file quarantined, Server-Sent Events read by a real socket client (backlog, live, Last-Event-ID replay,
// keep-alive, the stream cap), bad input (each a 4xx with a JSON body and nothing stored) and auth on writes.
// Eigen (gltf_io.h) before httplib.h: a macro of the headers httplib pulls in breaks Eigen's product kernels.
#include "gltf/gltf_io.h"

#include <gtest/gtest.h>
#include <httplib.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <filesystem>
#include <fstream>
#include <optional>
#include <regex>
#include <thread>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "tests/common/gltf_validator.h"
#include "tests/common/test_data.h"
#include "tests/service/mission_keyframes.h"
#include "tests/service/raw_http.h"
#include "tests/service/server_process.h"

namespace fs = std::filesystem;
using nlohmann::json;
using rgbdcast::test::MissionKeyframeFile;
using rgbdcast::test::ServerProcess;

namespace {

// GET `path` with extra header lines (each ending in CRLF), as sent: no client library decompressing the answer.
rgbdcast::test::RawResponse raw_get(int port, const std::string& path, const std::string& headers) {
  return rgbdcast::test::raw_request(port, "GET " + path + " HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port) +
                                               "\r\nConnection: close\r\n" + headers + "\r\n");
}

const std::vector<MissionKeyframeFile>& keyframes() {
  static std::string error;
  static const auto k = rgbdcast::test::mission_keyframes({0, 40, 80, 119}, &error);
  if (k.empty()) ADD_FAILURE() << error;
  return k;
}

#define REQUIRE_KEYFRAMES()                        \
  do {                                             \
    REQUIRE_DATA(rgbdcast::test::kMissionExcerpt); \
    ASSERT_EQ(keyframes().size(), 4u);             \
  } while (0)

std::unique_ptr<httplib::Client> client(int port) {
  auto c = std::make_unique<httplib::Client>("127.0.0.1", port);
  c->set_read_timeout(120, 0);
  return c;
}

std::string keyframe_path(const std::string& mission, int seq, const std::string& pose, double captured = 0) {
  std::string p = "/v1/missions/" + mission + "/keyframes?seq=" + std::to_string(seq) + "&pose=" + pose;
  if (captured > 0) p += "&captured=" + std::to_string(captured);
  return p;
}

httplib::Result post_keyframe(httplib::Client& c, const std::string& mission, int seq, const MissionKeyframeFile& k,
                              const httplib::Headers& headers = {}) {
  return c.Post(keyframe_path(mission, seq, k.pose, k.captured).c_str(), headers, k.glb, "model/gltf-binary");
}

void expect_json_error(const httplib::Result& r, int status, const std::string& what) {
  ASSERT_TRUE(r) << what << ": no response";
  EXPECT_EQ(r->status, status) << what << ": " << r->body;
  EXPECT_NE(r->get_header_value("Content-Type").find("application/json"), std::string::npos) << what;
  const json body = json::parse(r->body, nullptr, false);
  ASSERT_TRUE(body.is_object()) << what << ": " << r->body;
  EXPECT_TRUE(body.contains("error") && body["error"].is_string()) << what << ": " << r->body;
  EXPECT_TRUE(body.contains("detail") && body["detail"].is_string()) << what << ": " << r->body;
}

size_t files_under(const std::string& dir) {
  if (!fs::exists(dir)) return 0;
  size_t n = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) ++n;
  return n;
}

// Waits until the mission's views draw its settled tileset alone (X-Pending-Keyframes: 0, X-Stale-Tiles: 0), at
// most timeout_s.
bool wait_for_tileset(httplib::Client& c, const std::string& mission, double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  const std::string path = "/v1/missions/" + mission + "/view?pose=capture&width=32&height=24";
  while (std::chrono::steady_clock::now() < deadline) {
    auto r = c.Get(path.c_str());
    if (r && r->status == 200 && r->get_header_value("X-Pending-Keyframes") == "0" &&
        r->get_header_value("X-Tileset-Version") != "0" && r->get_header_value("X-Stale-Tiles") == "0")
      return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return false;
}

// An integer response header, 0 when absent.
int header_int(const httplib::Result& r, const char* name) {
  return r->has_header(name) ? std::stoi(r->get_header_value(name)) : 0;
}

// PSNR in dB of two encoded images of the same size (RGB, peak 255; 99 when identical).
double psnr_db(const std::string& a, const std::string& b) {
  auto decode = [](const std::string& s) {
    return cv::imdecode(cv::Mat(1, static_cast<int>(s.size()), CV_8U, const_cast<char*>(s.data())), cv::IMREAD_COLOR);
  };
  const cv::Mat x = decode(a), y = decode(b);
  if (x.empty() || x.size() != y.size()) return -1;
  const double mse = cv::norm(x, y, cv::NORM_L2SQR) / static_cast<double>(x.total() * 3);
  return mse == 0 ? 99.0 : 10.0 * std::log10(255.0 * 255.0 / mse);
}

// Fraction of pixels of a decoded JPEG view that are not background.
double covered(const std::string& jpeg) {
  const cv::Mat img =
      cv::imdecode(cv::Mat(1, static_cast<int>(jpeg.size()), CV_8U, const_cast<char*>(jpeg.data())), cv::IMREAD_COLOR);
  if (img.empty()) return -1;
  size_t n = 0;
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x) {
      const auto p = img.at<cv::Vec3b>(y, x);
      if (std::max({p[0], p[1], p[2]}) > 8) ++n;
    }
  return static_cast<double>(n) / static_cast<double>(img.total());
}

// The answer JSON of the wire contract, field by field.
void expect_answer_shape(const json& a, const std::string& mission, int seq) {
  ASSERT_TRUE(a.is_object()) << a;
  EXPECT_EQ(a.size(), 9u) << a;
  EXPECT_EQ(a["mission"], mission);
  EXPECT_EQ(a["seq"], seq);
  EXPECT_TRUE(a["rev"].is_number_unsigned()) << a;
  EXPECT_TRUE(a["bytes"].is_number_unsigned()) << a;
  EXPECT_TRUE(a["triangles"].is_number_unsigned()) << a;
  EXPECT_GT(a["triangles"].get<int>(), 100) << a;
  for (const char* t : {"captured", "received", "available", "first_available"})
    EXPECT_TRUE(a[t].is_number()) << t << ": " << a;
  EXPECT_LE(a["first_available"].get<double>(), a["available"].get<double>()) << a;
  EXPECT_GT(a["first_available"].get<double>(), 0) << a;
  if (a["rev"] == 0) {
    EXPECT_EQ(a["first_available"], a["available"]) << a;
  }
  EXPECT_GE(a["available"].get<double>(), a["received"].get<double>()) << a;
}

// An SSE client on a raw socket: what arrived, split into events.
struct SseEvent {
  std::string id, event, data;
};
class SseClient {
 public:
  SseClient(int port, const std::string& path, const std::string& last_event_id = "") {
    fd_ = rgbdcast::test::connect_loopback(port);
    std::string req =
        "GET " + path + " HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port) + "\r\nAccept: text/event-stream\r\n";
    if (!last_event_id.empty()) req += "Last-Event-ID: " + last_event_id + "\r\n";
    req += "\r\n";
    rgbdcast::test::send_all(fd_, req);
  }
  ~SseClient() {
    if (fd_ >= 0) ::close(fd_);
  }
  // Reads until `pred(text)` holds or timeout; returns whether it held. The text is the raw bytes (chunk framing
  // included: events are matched inside).
  template <class P>
  bool read_until(P pred, double timeout_s) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (!pred(text_)) {
      const int left = static_cast<int>(
          std::chrono::duration_cast<std::chrono::milliseconds>(end - std::chrono::steady_clock::now()).count());
      if (left <= 0) return false;
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, left) <= 0) return false;
      char buf[8192];
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) {
        closed_ = true;
        return pred(text_);
      }
      text_.append(buf, static_cast<size_t>(n));
    }
    return true;
  }
  std::vector<SseEvent> events() const {
    std::vector<SseEvent> out;
    std::regex re(R"(id: ([0-9-]+)\nevent: (\w+)\ndata: (\{[^\n]*\})\n\n)");
    for (std::sregex_iterator it(text_.begin(), text_.end(), re), end; it != end; ++it)
      out.push_back({(*it)[1], (*it)[2], (*it)[3]});
    return out;
  }
  const std::string& text() const { return text_; }
  bool closed() const { return closed_; }

 private:
  int fd_ = -1;
  std::string text_;
  bool closed_ = false;
};

// A test's folder, removed at the end when the test passed (declared before the server, so removed after it stops).
struct TestDir {
  std::string path;
  explicit TestDir(const std::string& tag) : path(rgbdcast::test::temp_dir(tag)) {}
  ~TestDir() {
    if (!::testing::Test::HasFailure()) rgbdcast::test::remove_tree_quietly(path);
  }
};

std::vector<std::string> ids_of(const std::vector<SseEvent>& events) {
  std::vector<std::string> ids;
  for (const auto& e : events) ids.push_back(e.id);
  return ids;
}

}  // namespace

TEST(Missions, PostIsIdempotentAndConflictsAre409) {
  REQUIRE_KEYFRAMES();
  const auto& k = keyframes();
  const TestDir test_dir("missions-idem");
  const std::string dir = test_dir.path;
  ServerProcess server;
  std::string error;
  ASSERT_TRUE(server.start(dir, {}, &error)) << error;
  auto c = client(server.port());

  auto first = post_keyframe(*c, "corridor-1", 0, k[0]);
  ASSERT_TRUE(first);
  ASSERT_EQ(first->status, 201) << first->body;
  const json a = json::parse(first->body);
  expect_answer_shape(a, "corridor-1", 0);
  EXPECT_EQ(a["bytes"], k[0].glb.size());
  EXPECT_NEAR(a["captured"].get<double>(), k[0].captured, 1e-3);
  const size_t stored_files = files_under(dir + "/missions");
  EXPECT_EQ(stored_files, 2u);  // 0.glb + 0.json

  // The same key, body and pose again: 200 and the very same JSON.
  auto again = post_keyframe(*c, "corridor-1", 0, k[0]);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->status, 200) << again->body;
  EXPECT_EQ(json::parse(again->body), a);

  // The same key with another body, or with another pose: 409, nothing stored.
  auto other_body = c->Post(keyframe_path("corridor-1", 0, k[0].pose).c_str(), k[1].glb, "model/gltf-binary");
  expect_json_error(other_body, 409, "other body");
  EXPECT_EQ(json::parse(other_body->body)["error"], "conflict");
  auto other_pose = c->Post(keyframe_path("corridor-1", 0, k[1].pose).c_str(), k[0].glb, "model/gltf-binary");
  expect_json_error(other_pose, 409, "other pose");
  EXPECT_EQ(files_under(dir + "/missions"), stored_files);

  auto second = post_keyframe(*c, "corridor-1", 1, k[1]);
  ASSERT_TRUE(second);
  ASSERT_EQ(second->status, 201) << second->body;

  auto list = c->Get("/v1/missions");
  ASSERT_TRUE(list);
  ASSERT_EQ(list->status, 200);
  const json l = json::parse(list->body);
  EXPECT_EQ(l["count"], 1);
  ASSERT_EQ(l["missions"].size(), 1u);
  const json m = l["missions"][0];
  EXPECT_EQ(m["name"], "corridor-1");
  EXPECT_EQ(m["keyframes"], 2);
  EXPECT_EQ(m["bytes"], k[0].glb.size() + k[1].glb.size());
  EXPECT_TRUE(m["updated"].is_number());

  auto one = c->Get("/v1/missions/corridor-1");
  ASSERT_TRUE(one);
  ASSERT_EQ(one->status, 200) << one->body;
  const json d = json::parse(one->body);
  EXPECT_EQ(d["name"], "corridor-1");
  ASSERT_EQ(d["keyframes"].size(), 2u);
  EXPECT_EQ(d["keyframes"][0]["seq"], 0);
  EXPECT_EQ(d["keyframes"][1]["seq"], 1);
  ASSERT_EQ(d["keyframes"][1]["pose"].size(), 7u);
  EXPECT_EQ(d["keyframes"][0]["available"], a["available"]);
  EXPECT_EQ(d["bytes"], m["bytes"]);
  EXPECT_EQ(d["triangles"].get<int>(),
            d["keyframes"][0]["triangles"].get<int>() + d["keyframes"][1]["triangles"].get<int>());

  auto del = c->Delete("/v1/missions/corridor-1");
  ASSERT_TRUE(del);
  EXPECT_EQ(del->status, 204);
  expect_json_error(c->Get("/v1/missions/corridor-1"), 404, "deleted mission");
  EXPECT_EQ(files_under(dir + "/missions"), 0u);
}

TEST(Missions, ViewsGrowIncrementallyAndModelIsOneValidGlb) {
  REQUIRE_KEYFRAMES();
  const auto& k = keyframes();
  const TestDir test_dir("missions-views");
  const std::string dir = test_dir.path;
  ServerProcess server;
  std::string error;
  // One renderer: every view is served by the worker that holds the mission's parts, so X-Parts-Loaded counts
  // what a view had to load (service/mission_view.h): never the mission again, only what changed.
  ASSERT_TRUE(server.start(dir, {"--renderers", "1"}, &error)) << error;
  auto c = client(server.port());
  // A fixed wide view from behind and above the start, looking into the room.
  const std::string fixed = "/v1/missions/lab/view?eye=0,-0.3,-1.2&target=0,0,1.5&fov=90&width=320&height=240";
  std::vector<double> coverage;
  for (int i = 0; i < 4; ++i) {
    auto r = post_keyframe(*c, "lab", i, k[static_cast<size_t>(i)]);
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 201) << r->body;
    auto v = c->Get(fixed.c_str());
    ASSERT_TRUE(v);
    ASSERT_EQ(v->status, 200) << v->body;
    const int drawn = header_int(v, "X-Parts-Drawn");
    const int loaded = header_int(v, "X-Parts-Loaded");
    EXPECT_GE(drawn, 1) << i;
    EXPECT_LE(loaded, drawn) << i;
    EXPECT_EQ(header_int(v, "X-Render-Batches"), 1) << i;  // a few parts fit the default cap together
    auto same = c->Get(fixed.c_str());  // nothing new: nothing loaded, unless the tileset moved on meanwhile
    ASSERT_TRUE(same && same->status == 200);
    if (same->get_header_value("X-Tileset-Version") == v->get_header_value("X-Tileset-Version")) {
      EXPECT_EQ(same->get_header_value("X-Parts-Loaded"), "0") << i;
    }
    coverage.push_back(covered(v->body));
  }
  // The tile worker catches up: the views then draw the tileset alone, and stay the same.
  ASSERT_TRUE(wait_for_tileset(*c, "lab", 60.0));
  for (size_t i = 1; i < coverage.size(); ++i) EXPECT_GE(coverage[i], coverage[i - 1] - 1e-3) << i;
  EXPECT_GT(coverage.back(), coverage.front() + 0.01) << coverage.front() << " -> " << coverage.back();

  // pose=capture is the newest keyframe's camera; pose=keyframe:N a given one.
  auto cap = c->Get("/v1/missions/lab/view?pose=capture&format=png&width=160&height=120");
  auto kf3 = c->Get("/v1/missions/lab/view?pose=keyframe:3&format=png&width=160&height=120");
  auto kf0 = c->Get("/v1/missions/lab/view?pose=keyframe:0&format=png&width=160&height=120");
  ASSERT_TRUE(cap && kf3 && kf0);
  ASSERT_EQ(cap->status, 200) << cap->body;
  EXPECT_EQ(cap->body, kf3->body);
  EXPECT_NE(cap->body, kf0->body);
  expect_json_error(c->Get("/v1/missions/lab/view?pose=keyframe:9"), 404, "unknown keyframe");
  expect_json_error(c->Get("/v1/missions/lab/view?pose=keyframe:x"), 400, "bad keyframe");
  expect_json_error(c->Get("/v1/missions/lab/view?width=9999&pose=capture"), 400, "bad width");

  auto glb = c->Get("/v1/missions/lab/model.glb");
  ASSERT_TRUE(glb);
  ASSERT_EQ(glb->status, 200) << glb->body;
  EXPECT_EQ(glb->get_header_value("Content-Type"), "model/gltf-binary");
  auto scene = rgbdcast::decode_glb(reinterpret_cast<const std::uint8_t*>(glb->body.data()), glb->body.size());
  ASSERT_TRUE(scene) << scene.error().message;
  EXPECT_EQ(scene->nodes.size(), 4u);
  EXPECT_EQ(scene->cameras.size(), 4u);
  size_t triangles = 0;
  const json listed = json::parse(c->Get("/v1/missions/lab")->body);
  for (const auto& f : listed["keyframes"]) triangles += f["triangles"].get<size_t>();
  EXPECT_EQ(scene->triangle_count(), triangles);
  // Keyframe 3's camera sits where its pose says (world frame).
  const json pose = listed["keyframes"][3]["pose"];
  EXPECT_NEAR(scene->cameras[3].camera_to_world(0, 3), pose[0].get<double>(), 1e-4);
  EXPECT_NEAR(scene->cameras[3].camera_to_world(2, 3), pose[2].get<double>(), 1e-4);
  // Encoded once per change of the mission: the same bytes from the cache, 304 for a current copy.
  EXPECT_EQ(glb->get_header_value("X-Model-Cache"), "miss");
  auto again = c->Get("/v1/missions/lab/model.glb");
  ASSERT_TRUE(again);
  EXPECT_EQ(again->get_header_value("X-Model-Cache"), "hit");
  EXPECT_EQ(again->body, glb->body);
  const std::string etag = glb->get_header_value("ETag");
  ASSERT_FALSE(etag.empty());
  auto current = c->Get("/v1/missions/lab/model.glb", {{"If-None-Match", etag}});
  ASSERT_TRUE(current);
  EXPECT_EQ(current->status, 304);
  const std::string path = dir + "/mission.glb";
  std::ofstream(path, std::ios::binary) << glb->body;
  EXPECT_GLTF_VALID(path);

  // ?flavor=compat, as for scenes: plain floats (no meshopt), the same nodes, cameras and triangles; cached on its
  // own; a bad flavour is a 400 with a JSON body.
  auto compat = c->Get("/v1/missions/lab/model.glb?flavor=compat");
  ASSERT_TRUE(compat);
  ASSERT_EQ(compat->status, 200) << compat->body;
  EXPECT_EQ(compat->get_header_value("X-Model-Cache"), "miss");
  EXPECT_EQ(compat->body.find("EXT_meshopt_compression"), std::string::npos);
  EXPECT_NE(glb->body.find("EXT_meshopt_compression"), std::string::npos);
  EXPECT_NE(compat->get_header_value("ETag"), etag);
  EXPECT_NE(compat->get_header_value("Content-Disposition").find("lab-compat.glb"), std::string::npos);
  auto compat_scene =
      rgbdcast::decode_glb(reinterpret_cast<const std::uint8_t*>(compat->body.data()), compat->body.size());
  ASSERT_TRUE(compat_scene) << compat_scene.error().message;
  EXPECT_EQ(compat_scene->nodes.size(), 4u);
  EXPECT_EQ(compat_scene->cameras.size(), 4u);
  EXPECT_EQ(compat_scene->triangle_count(), triangles);
  auto compat_again = c->Get("/v1/missions/lab/model.glb?flavor=compat");
  ASSERT_TRUE(compat_again);
  EXPECT_EQ(compat_again->get_header_value("X-Model-Cache"), "hit");
  const std::string compat_path = dir + "/mission-compat.glb";
  std::ofstream(compat_path, std::ios::binary) << compat->body;
  EXPECT_GLTF_VALID(compat_path);
  expect_json_error(c->Get("/v1/missions/lab/model.glb?flavor=png"), 400, "unknown flavor");

  // Each listed keyframe carries its capture camera's intrinsics (the operator page's overlay projects with them).
  for (const auto& f : listed["keyframes"]) {
    ASSERT_TRUE(f.contains("intrinsics")) << f.dump();
    EXPECT_GT(f["intrinsics"]["fx"].get<double>(), 100) << f.dump();
    EXPECT_GT(f["intrinsics"]["width"].get<int>(), 0) << f.dump();
    EXPECT_GT(f["intrinsics"]["cx"].get<double>(), 0) << f.dump();
  }
}

TEST(Missions, RestartMidMissionLosesAndDuplicatesNothing) {
  REQUIRE_KEYFRAMES();
  const auto& k = keyframes();
  const TestDir test_dir("missions-restart");
  const std::string dir = test_dir.path;
  std::string error;
  json before;
  std::string answer1;
  {
    ServerProcess server;
    ASSERT_TRUE(server.start(dir, {}, &error)) << error;
    auto c = client(server.port());
    ASSERT_EQ(post_keyframe(*c, "m", 0, k[0])->status, 201);
    auto r1 = post_keyframe(*c, "m", 1, k[1]);
    ASSERT_EQ(r1->status, 201);
    answer1 = r1->body;
    before = json::parse(c->Get("/v1/missions/m")->body);
    server.kill9();  // no clean shutdown
  }
  // A corrupt keyframe file of another mission, and a leftover temporary file: quarantined and cleaned, not fatal.
  fs::create_directories(dir + "/missions/broken");
  std::ofstream(dir + "/missions/broken/0.json") << "{\"seq\": \"zero\"";
  std::ofstream(dir + "/missions/broken/0.glb") << "x";
  std::ofstream(dir + "/missions/m/.tmp-2.glb-abcd") << "half";
  ServerProcess server;
  ASSERT_TRUE(server.start(dir, {}, &error)) << error;
  EXPECT_NE(server.output().find("quarantine"), std::string::npos) << server.output();
  EXPECT_TRUE(fs::exists(dir + "/quarantine/mission-broken-0.json"));
  EXPECT_FALSE(fs::exists(dir + "/missions/m/.tmp-2.glb-abcd"));
  auto c = client(server.port());
  EXPECT_EQ(json::parse(c->Get("/v1/missions/m")->body), before);
  expect_json_error(c->Get("/v1/missions/broken"), 404, "quarantined mission");

  // The sender, unsure whether keyframe 1 arrived, sends it again: the same answer, not a second copy.
  auto again = post_keyframe(*c, "m", 1, k[1]);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->status, 200);
  EXPECT_EQ(json::parse(again->body), json::parse(answer1));
  ASSERT_EQ(post_keyframe(*c, "m", 2, k[2])->status, 201);
  const json after = json::parse(c->Get("/v1/missions/m")->body);
  ASSERT_EQ(after["keyframes"].size(), 3u);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(after["keyframes"][i]["seq"], i);
  SseClient sse(server.port(), "/v1/missions/m/events");
  ASSERT_TRUE(sse.read_until([](const std::string& t) { return t.find("id: 2\n") != std::string::npos; }, 10))
      << sse.text();
  EXPECT_EQ(ids_of(sse.events()), (std::vector<std::string>{"0", "1", "2"})) << sse.text();
  auto glb = c->Get("/v1/missions/m/model.glb");
  auto scene = rgbdcast::decode_glb(reinterpret_cast<const std::uint8_t*>(glb->body.data()), glb->body.size());
  ASSERT_TRUE(scene);
  EXPECT_EQ(scene->nodes.size(), 3u);
}

TEST(Missions, EventsReachARealClientWithReplayAndKeepAlive) {
  REQUIRE_KEYFRAMES();
  const auto& k = keyframes();
  const TestDir test_dir("missions-sse");
  const std::string dir = test_dir.path;
  ServerProcess server;
  std::string error;
  // Streams live 20 s: on a loaded 2-core machine the steps below (three posts, a replay) took more than 6 s, the
  // first stream ended early and the third was not refused; at 12 s the test failed once more under the sanitizers
  // beside other work. A failure of the refusal says how long the first stream had been open.
  constexpr double kStreamMaxS = 20;
  ASSERT_TRUE(server.start(
      dir, {"--keep-alive-s", "0.5", "--max-event-streams", "2", "--event-stream-max-s", std::to_string(kStreamMaxS)},
      &error))
      << error;
  auto c = client(server.port());
  ASSERT_EQ(post_keyframe(*c, "live", 0, k[0])->status, 201);
  ASSERT_EQ(post_keyframe(*c, "live", 1, k[1])->status, 201);

  SseClient all(server.port(), "/v1/missions/live/events");
  const auto all_opened = std::chrono::steady_clock::now();
  auto all_open_s = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - all_opened).count();
  };
  ASSERT_TRUE(all.read_until([](const std::string& t) { return t.find("id: 1\n") != std::string::npos; }, 10))
      << all.text();
  EXPECT_NE(all.text().find("Content-Type: text/event-stream"), std::string::npos) << all.text();
  // A live keyframe arrives on the open stream.
  ASSERT_EQ(post_keyframe(*c, "live", 2, k[2])->status, 201);
  ASSERT_TRUE(all.read_until([](const std::string& t) { return t.find("id: 2\n") != std::string::npos; }, 10))
      << all.text();
  const auto events = all.events();
  ASSERT_EQ(ids_of(events), (std::vector<std::string>{"0", "1", "2"})) << all.text();
  for (const auto& e : events) {
    EXPECT_EQ(e.event, "keyframe");
    expect_answer_shape(json::parse(e.data), "live", std::stoi(e.id));
  }
  EXPECT_TRUE(all.read_until([](const std::string& t) { return t.find(": keep-alive\n\n") != std::string::npos; }, 5))
      << all.text();

  // Last-Event-ID (header) and ?last_event_id= replay only what came after.
  SseClient replay(server.port(), "/v1/missions/live/events", "0");
  ASSERT_TRUE(replay.read_until([](const std::string& t) { return t.find("id: 2\n") != std::string::npos; }, 10));
  EXPECT_EQ(ids_of(replay.events()), (std::vector<std::string>{"1", "2"})) << replay.text();
  // Two streams are open: a third gets 503 with Retry-After and a JSON body.
  auto third = rgbdcast::test::raw_request(server.port(),
                                           "GET /v1/missions/live/events?last_event_id=1 HTTP/1.1\r\nHost: 127.0.0.1:" +
                                               std::to_string(server.port()) + "\r\n\r\n");
  EXPECT_EQ(third.status, 503) << third.body << " (the first stream had been open " << all_open_s() << " s of "
                               << kStreamMaxS << ")";
  EXPECT_TRUE(third.headers.count("retry-after"));
  EXPECT_TRUE(json::parse(third.body, nullptr, false).is_object()) << third.body;
  // Streams end after --event-stream-max-s; the server stays healthy (the threads came back).
  EXPECT_TRUE(
      all.read_until([](const std::string& t) { return t.find("0\r\n\r\n") != std::string::npos; }, kStreamMaxS + 10))
      << all.text();
  SseClient later(server.port(), "/v1/missions/live/events?last_event_id=1");
  ASSERT_TRUE(later.read_until([](const std::string& t) { return t.find("id: 2\n") != std::string::npos; }, 10))
      << later.text();
  EXPECT_EQ(ids_of(later.events()), (std::vector<std::string>{"2"}));
  auto health = c->Get("/healthz");
  ASSERT_TRUE(health);
  EXPECT_EQ(health->status, 200);
  EXPECT_EQ(json::parse(health->body)["missions"], 1);
  auto metrics = c->Get("/metrics");
  ASSERT_TRUE(metrics);
  EXPECT_NE(metrics->body.find("rgbdcast_missions_stored 1\n"), std::string::npos);
  std::smatch open_streams;
  ASSERT_TRUE(std::regex_search(metrics->body, open_streams, std::regex("rgbdcast_event_streams_open (\\d+)\n")));
  EXPECT_GE(std::stoi(open_streams[1]), 1) << "'later' is open";  // 'replay' too unless its 12 s are over
  EXPECT_LE(std::stoi(open_streams[1]), 2) << "'all' ended";
  expect_json_error(c->Get("/v1/missions/nope/events"), 404, "events of unknown mission");
  expect_json_error(c->Get("/v1/missions/live/events?last_event_id=abc"), 400, "bad last event id");
}

TEST(Missions, BadInputIs4xxWithJsonAndStoresNothing) {
  REQUIRE_KEYFRAMES();
  const auto& k = keyframes();
  const TestDir test_dir("missions-bad");
  const std::string dir = test_dir.path;
  ServerProcess server;
  std::string error;
  ASSERT_TRUE(server.start(dir, {}, &error)) << error;
  auto c = client(server.port());
  const std::string good_pose = k[0].pose;
  auto post = [&](const std::string& path, const std::string& body, const std::string& type = "model/gltf-binary") {
    return c->Post(path.c_str(), body, type.c_str());
  };
  struct Case {
    std::string what, path, body, type;
    int status;
  };
  const std::string g = k[0].glb;
  const std::vector<Case> cases = {
      {"bad name", "/v1/missions/bad.name/keyframes?seq=0&pose=" + good_pose, g, "model/gltf-binary", 400},
      {"name too long", "/v1/missions/" + std::string(65, 'a') + "/keyframes?seq=0&pose=" + good_pose, g,
       "model/gltf-binary", 400},
      {"no seq", "/v1/missions/m/keyframes?pose=" + good_pose, g, "model/gltf-binary", 400},
      {"negative seq", "/v1/missions/m/keyframes?seq=-1&pose=" + good_pose, g, "model/gltf-binary", 400},
      {"seq over 2^31-1", "/v1/missions/m/keyframes?seq=2147483648&pose=" + good_pose, g, "model/gltf-binary", 400},
      {"no pose", "/v1/missions/m/keyframes?seq=0", g, "model/gltf-binary", 400},
      {"nan pose", "/v1/missions/m/keyframes?seq=0&pose=nan,0,0,0,0,0,1", g, "model/gltf-binary", 400},
      {"inf pose", "/v1/missions/m/keyframes?seq=0&pose=0,inf,0,0,0,0,1", g, "model/gltf-binary", 400},
      {"6 numbers", "/v1/missions/m/keyframes?seq=0&pose=0,0,0,0,0,1", g, "model/gltf-binary", 400},
      {"8 numbers", "/v1/missions/m/keyframes?seq=0&pose=0,0,0,0,0,0,1,1", g, "model/gltf-binary", 400},
      {"non-unit quaternion", "/v1/missions/m/keyframes?seq=0&pose=0,0,0,0,0,0,1.01", g, "model/gltf-binary", 400},
      {"zero quaternion", "/v1/missions/m/keyframes?seq=0&pose=0,0,0,0,0,0,0", g, "model/gltf-binary", 400},
      {"unknown parameter", "/v1/missions/m/keyframes?seq=0&pose=" + good_pose + "&x=1", g, "model/gltf-binary", 400},
      {"captured nan", "/v1/missions/m/keyframes?seq=0&captured=nan&pose=" + good_pose, g, "model/gltf-binary", 400},
      {"not a GLB", "/v1/missions/m/keyframes?seq=0&pose=" + good_pose, "this is not a GLB", "model/gltf-binary", 422},
      {"truncated GLB", "/v1/missions/m/keyframes?seq=0&pose=" + good_pose, g.substr(0, g.size() / 2),
       "model/gltf-binary", 422},
      {"wrong type", "/v1/missions/m/keyframes?seq=0&pose=" + good_pose, g, "image/png", 415},
  };
  for (const auto& cs : cases) {
    expect_json_error(post(cs.path, cs.body, cs.type), cs.status, cs.what);
    EXPECT_EQ(files_under(dir + "/missions"), 0u) << cs.what;
  }
  EXPECT_EQ(json::parse(c->Get("/v1/missions")->body)["count"], 0) << "something was stored";
  expect_json_error(c->Get("/v1/missions/nope"), 404, "unknown mission");
  expect_json_error(c->Get("/v1/missions/nope/view?pose=capture"), 404, "view of unknown mission");
  expect_json_error(c->Get("/v1/missions/nope/model.glb"), 404, "model of unknown mission");
  expect_json_error(c->Delete("/v1/missions/nope"), 404, "delete unknown mission");
  expect_json_error(c->Get("/v1/missions/bad.name"), 400, "bad name");
  expect_json_error(c->Put("/v1/missions/m/keyframes", g, "model/gltf-binary"), 405, "PUT");
}

TEST(Missions, WritesNeedTheTokenWhenOneIsSet) {
  REQUIRE_KEYFRAMES();
  const auto& k = keyframes();
  const TestDir test_dir("missions-auth");
  const std::string dir = test_dir.path;
  std::ofstream(dir + "/token") << "s3cret-token-for-tests\n";
  ServerProcess server;
  std::string error;
  ASSERT_TRUE(server.start(dir + "/data", {"--token-file", dir + "/token"}, &error)) << error;
  auto c = client(server.port());
  expect_json_error(post_keyframe(*c, "m", 0, k[0]), 401, "post without token");
  expect_json_error(post_keyframe(*c, "m", 0, k[0], {{"Authorization", "Bearer wrong"}}), 401, "wrong token");
  // A page of another origin cannot post even with the token (CSRF, DNS rebinding).
  expect_json_error(
      post_keyframe(*c, "m", 0, k[0],
                    {{"Authorization", "Bearer s3cret-token-for-tests"}, {"Origin", "http://evil.example"}}),
      403, "foreign origin");
  EXPECT_EQ(files_under(dir + "/data/missions"), 0u);
  const httplib::Headers auth = {{"Authorization", "Bearer s3cret-token-for-tests"}};
  auto ok = post_keyframe(*c, "m", 0, k[0], auth);
  ASSERT_TRUE(ok);
  EXPECT_EQ(ok->status, 201) << ok->body;
  auto get = c->Get("/v1/missions/m");  // reads need no token
  ASSERT_TRUE(get);
  EXPECT_EQ(get->status, 200);
  expect_json_error(c->Delete("/v1/missions/m"), 401, "delete without token");
  auto del = c->Delete("/v1/missions/m", auth);
  ASSERT_TRUE(del);
  EXPECT_EQ(del->status, 204);
}

// A refinement: the sender re-posts keyframe 0 under rev=1 with a finer body. It replaces the stored keyframe (the
// mission keeps one node per seq, views and model.glb show the new body), a re-post of (0, 1) is idempotent, another
// body under (0, 1) is a 409, rev 0 again is a 409 "stale_revision", the revision is an SSE event "0-1", and a
// restart keeps revision 1.
TEST(Missions, ARevisionReplacesTheKeyframeIdempotentlyAndSurvivesARestart) {
  REQUIRE_KEYFRAMES();
  const auto& k = keyframes();
  const TestDir test_dir("missions-rev");
  const std::string dir = test_dir.path;
  std::string error;
  json after_revision;
  {
    ServerProcess server;
    ASSERT_TRUE(server.start(dir, {}, &error)) << error;
    auto c = client(server.port());
    ASSERT_EQ(post_keyframe(*c, "m", 0, k[0])->status, 201);
    ASSERT_EQ(post_keyframe(*c, "m", 1, k[1])->status, 201);
    const json first = json::parse(c->Get("/v1/missions/m")->body);
    auto view_before = c->Get("/v1/missions/m/view?pose=keyframe:0&width=320&height=240");
    ASSERT_TRUE(view_before);
    ASSERT_EQ(view_before->status, 200);

    // Revision 1 of seq 0: another real keyframe's body (k[2]) at seq 0's pose.
    const std::string rev1 = keyframe_path("m", 0, k[0].pose, k[0].captured) + "&rev=1";
    auto replaced = c->Post(rev1.c_str(), k[2].glb, "model/gltf-binary");
    ASSERT_TRUE(replaced);
    ASSERT_EQ(replaced->status, 201) << replaced->body;
    const json r = json::parse(replaced->body);
    expect_answer_shape(r, "m", 0);
    EXPECT_EQ(r["rev"], 1);
    EXPECT_EQ(r["bytes"], k[2].glb.size());
    EXPECT_EQ(r["first_available"], first["keyframes"][0]["available"]);  // the seq was viewable since then
    EXPECT_GE(r["available"].get<double>(), r["first_available"].get<double>());
    EXPECT_EQ(files_under(dir + "/missions"), 4u);  // 0.r1.glb, 0.json, 1.glb, 1.json: the old body is gone

    auto again = c->Post(rev1.c_str(), k[2].glb, "model/gltf-binary");
    ASSERT_TRUE(again);
    EXPECT_EQ(again->status, 200) << again->body;
    EXPECT_EQ(json::parse(again->body), r);
    auto other = c->Post(rev1.c_str(), k[3].glb, "model/gltf-binary");
    expect_json_error(other, 409, "another body under the same revision");
    EXPECT_EQ(json::parse(other->body)["error"], "conflict");
    auto stale = post_keyframe(*c, "m", 0, k[0]);
    expect_json_error(stale, 409, "the older revision");
    EXPECT_EQ(json::parse(stale->body)["error"], "stale_revision");
    EXPECT_EQ(json::parse(stale->body)["stored"]["rev"], 1);
    expect_json_error(c->Post((keyframe_path("m", 0, k[0].pose) + "&rev=x").c_str(), k[2].glb, "model/gltf-binary"),
                      400, "a rev that is not a number");
    EXPECT_EQ(files_under(dir + "/missions"), 4u);

    after_revision = json::parse(c->Get("/v1/missions/m")->body);
    ASSERT_EQ(after_revision["keyframes"].size(), 2u);
    EXPECT_EQ(after_revision["keyframes"][0]["rev"], 1);
    EXPECT_EQ(after_revision["keyframes"][0]["bytes"], k[2].glb.size());
    EXPECT_EQ(after_revision["bytes"], k[2].glb.size() + k[1].glb.size());

    // The merged model: one node per seq, seq 0's being the revision (k[2]'s triangles).
    auto glb = c->Get("/v1/missions/m/model.glb");
    ASSERT_TRUE(glb);
    auto scene = rgbdcast::decode_glb(reinterpret_cast<const std::uint8_t*>(glb->body.data()), glb->body.size());
    ASSERT_TRUE(scene) << scene.error().message;
    ASSERT_EQ(scene->nodes.size(), 2u);
    EXPECT_EQ(scene->triangle_count(), after_revision["triangles"].get<size_t>());
    EXPECT_EQ(after_revision["keyframes"][0]["triangles"], r["triangles"]);
    // The view from keyframe 0 now draws the revision's surface: it changed.
    auto view_after = c->Get("/v1/missions/m/view?pose=keyframe:0&width=320&height=240");
    ASSERT_TRUE(view_after);
    ASSERT_EQ(view_after->status, 200);
    EXPECT_NE(view_after->body, view_before->body);

    SseClient sse(server.port(), "/v1/missions/m/events");
    ASSERT_TRUE(sse.read_until([](const std::string& t) { return t.find("id: 0-1") != std::string::npos; }, 5.0))
        << sse.text();
    EXPECT_EQ(ids_of(sse.events()), (std::vector<std::string>{"0", "1", "0-1"})) << sse.text();
    SseClient resumed(server.port(), "/v1/missions/m/events", "1");
    ASSERT_TRUE(resumed.read_until([](const std::string& t) { return t.find("id: 0-1") != std::string::npos; }, 5.0));
    EXPECT_EQ(ids_of(resumed.events()), (std::vector<std::string>{"0-1"})) << resumed.text();
    server.kill9();
  }
  ServerProcess server;
  ASSERT_TRUE(server.start(dir, {}, &error)) << error;
  auto c = client(server.port());
  EXPECT_EQ(json::parse(c->Get("/v1/missions/m")->body), after_revision);
  EXPECT_EQ(json::parse(post_keyframe(*c, "m", 0, k[0])->body)["error"], "stale_revision");
  auto again =
      c->Post((keyframe_path("m", 0, k[0].pose, k[0].captured) + "&rev=1").c_str(), k[2].glb, "model/gltf-binary");
  ASSERT_TRUE(again);
  EXPECT_EQ(again->status, 200) << again->body;
  auto glb = c->Get("/v1/missions/m/model.glb");
  auto scene = rgbdcast::decode_glb(reinterpret_cast<const std::uint8_t*>(glb->body.data()), glb->body.size());
  ASSERT_TRUE(scene);
  EXPECT_EQ(scene->nodes.size(), 2u);
}

// /metrics of a live server that has served views (of a scene and of a mission), stored an upload, refused bad
// requests and taken a mission's keyframes passes Prometheus' own linter, `promtool check metrics` (Debian package
// prometheus): base units, _total counters, histograms for latencies.
TEST(Missions, MetricsPassPromtool) {
  REQUIRE_KEYFRAMES();
  if (rgbdcast::test::run_command("command -v promtool").exit_code != 0)
    RGBDCAST_MISSING_PREREQUISITE("promtool not found (Debian package prometheus; scripts/test.sh installs it)");
  const auto& k = keyframes();
  const TestDir test_dir("missions-promtool");
  ServerProcess server;
  std::string error;
  ASSERT_TRUE(server.start(test_dir.path, {}, &error)) << error;
  auto c = client(server.port());
  auto upload = c->Post("/v1/scenes", k[0].glb, "model/gltf-binary");
  ASSERT_TRUE(upload);
  ASSERT_EQ(upload->status, 201) << upload->body;
  const std::string id = json::parse(upload->body)["id"];
  for (int seq = 0; seq < 2; ++seq) {
    auto r = post_keyframe(*c, "promtool", seq, k[seq]);
    ASSERT_TRUE(r);
    ASSERT_LT(r->status, 300) << r->body;
  }
  for (const std::string& path : {"/v1/scenes/" + id + "/view?pose=capture&width=64&height=48",
                                  std::string("/v1/missions/promtool/view?pose=capture&width=64&height=48")}) {
    auto v = c->Get(path.c_str());
    ASSERT_TRUE(v);
    EXPECT_EQ(v->status, 200) << path << ": " << v->body;
  }
  expect_json_error(c->Get(("/v1/scenes/" + id + "/view?width=0").c_str()), 400, "bad width");
  expect_json_error(c->Get("/v1/missions/nope/view"), 404, "unknown mission");
  auto m = c->Get("/metrics");
  ASSERT_TRUE(m);
  ASSERT_EQ(m->status, 200);
  for (const char* family :
       {"rgbdcast_http_requests_total{", "rgbdcast_http_request_duration_seconds_bucket{",
        "rgbdcast_render_duration_seconds_bucket{", "rgbdcast_missions_stored 1\n", "rgbdcast_scenes_stored_bytes "})
    EXPECT_NE(m->body.find(family), std::string::npos) << family << "\n" << m->body;
  const std::string file = test_dir.path + "/metrics.txt";
  std::ofstream(file, std::ios::binary) << m->body;
  const auto check = rgbdcast::test::run_command("promtool check metrics < " + file);
  EXPECT_EQ(check.exit_code, 0) << check.out << check.err;
  EXPECT_EQ(check.out + check.err, "") << "promtool's findings on\n" << m->body;
}

// The mission as a live 3D Tiles 1.1 tileset: built in the background after the POSTs, announced by a "tileset" event,
// its tiles immutable files with strong ETags; hostile tile names are refused with a JSON 4xx.
TEST(Missions, TheTilesetFollowsTheKeyframesAndItsTilesAreImmutable) {
  REQUIRE_KEYFRAMES();
  const auto& k = keyframes();
  const TestDir test_dir("missions-tiles");
  ServerProcess server;
  std::string error;
  ASSERT_TRUE(server.start(test_dir.path, {}, &error)) << error;
  auto c = client(server.port());
  for (int i = 0; i < 3; ++i) ASSERT_EQ(post_keyframe(*c, "floor", i, k[static_cast<size_t>(i)])->status, 201);
  size_t posted = 0, newest = 0;
  const json mission = json::parse(c->Get("/v1/missions/floor")->body);
  for (const auto& e : mission["keyframes"]) {
    posted += e["triangles"].get<size_t>();
    if (e["seq"] == 2) newest = e["triangles"].get<size_t>();
  }
  ASSERT_GT(newest, 0u);
  std::function<void(const json&, std::vector<std::string>*)> walk = [&](const json& t, std::vector<std::string>* u) {
    if (t.contains("content")) u->push_back(t["content"]["uri"]);
    for (const auto& ch : t.value("children", json::array())) walk(ch, u);
  };
  // The triangles in the leaves, once the newest keyframe's leaf is among them (0 before, or when a tile was replaced
  // between the two reads).
  auto leaf_triangles = [&](const json& ts) {
    std::vector<std::string> u;
    walk(ts["root"], &u);
    if (std::none_of(u.begin(), u.end(), [](const std::string& uri) {
          return uri.rfind("tiles/0_", 0) == 0 && uri.find("_2.v") != std::string::npos;
        }))
      return size_t(0);
    size_t n = 0;
    for (const auto& uri : u) {
      if (uri.rfind("tiles/0_", 0) != 0) continue;
      auto r = c->Get(("/v1/missions/floor/" + uri).c_str());
      if (!r || r->status != 200) return size_t(0);  // replaced meanwhile: look again
      auto scene = rgbdcast::decode_glb(reinterpret_cast<const std::uint8_t*>(r->body.data()), r->body.size());
      if (scene) n += scene->triangle_count();
    }
    return n;
  };
  // Within 60 s the tileset holds every keyframe: the newest whole, the older ones less what it saw again.
  json tileset;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  size_t in_leaves = 0;
  while (std::chrono::steady_clock::now() < deadline) {
    auto r = c->Get("/v1/missions/floor/tileset.json");
    ASSERT_TRUE(r && r->status == 200);
    tileset = json::parse(r->body);
    if ((in_leaves = leaf_triangles(tileset)) > 0) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  EXPECT_GE(in_leaves, newest);
  EXPECT_LE(in_leaves, posted);
  // The event stream reports the tileset (without an id, so Last-Event-ID keeps naming keyframes).
  SseClient sse(server.port(), "/v1/missions/floor/events");
  ASSERT_TRUE(sse.read_until([](const std::string& t) { return t.find("event: tileset") != std::string::npos; }, 10))
      << sse.text();
  ASSERT_TRUE(sse.read_until([](const std::string& t) { return t.find("id: 2\n") != std::string::npos; }, 10));
  EXPECT_EQ(ids_of(sse.events()), (std::vector<std::string>{"0", "1", "2"})) << sse.text();
  EXPECT_EQ(tileset["asset"]["version"], "1.1");
  EXPECT_EQ(tileset["root"]["refine"], "REPLACE");
  // Every content URI is fetchable, a GLB that decodes, cacheable for good; If-None-Match answers 304.
  std::vector<std::string> uris;
  walk(tileset["root"], &uris);
  ASSERT_GT(uris.size(), 1u);
  for (const auto& uri : uris) {
    auto r = c->Get(("/v1/missions/floor/" + uri).c_str());
    ASSERT_TRUE(r && r->status == 200) << uri;
    EXPECT_EQ(r->get_header_value("Content-Type"), "model/gltf-binary");
    EXPECT_NE(r->get_header_value("Cache-Control").find("immutable"), std::string::npos);
    auto scene = rgbdcast::decode_glb(reinterpret_cast<const std::uint8_t*>(r->body.data()), r->body.size());
    ASSERT_TRUE(scene) << uri;
    auto again = c->Get(("/v1/missions/floor/" + uri).c_str(), {{"If-None-Match", r->get_header_value("ETag")}});
    ASSERT_TRUE(again);
    EXPECT_EQ(again->status, 304) << uri;
  }
  {
    auto r = c->Get(("/v1/missions/floor/" + uris.front()).c_str());
    const std::string path = test_dir.path + "/tile.glb";
    std::ofstream(path, std::ios::binary) << r->body;
    EXPECT_GLTF_VALID(path);
  }
  for (const char* bad : {"/v1/missions/floor/tiles/..%2F..%2Fmissions%2Ffloor%2F0.json",
                          "/v1/missions/floor/tiles/../missions/floor/0.glb", "/v1/missions/floor/tiles/hierarchy.json",
                          "/v1/missions/floor/tiles/0_0_0.v1.glb.tmp", "/v1/missions/floor/tiles/"})
    expect_json_error(c->Get(bad), 400, bad);
  // tileset.json gzipped for a client that offers gzip, as is for any other (not left to httplib's per-request
  // brotli); the same JSON either way, each representation with its own ETag, both answering If-None-Match.
  bool compared = false;
  for (int attempt = 0; attempt < 20 && !compared; ++attempt) {
    const auto plain = raw_get(server.port(), "/v1/missions/floor/tileset.json", "Accept-Encoding: br\r\n");
    const auto gz = raw_get(server.port(), "/v1/missions/floor/tileset.json", "Accept-Encoding: gzip, br\r\n");
    ASSERT_EQ(plain.status, 200);
    ASSERT_EQ(gz.status, 200);
    const std::string plain_tag = plain.headers.at("etag"), gz_tag = gz.headers.at("etag");
    if (gz_tag != plain_tag.substr(0, plain_tag.size() - 1) + "-gzip\"") continue;  // a commit in between
    EXPECT_EQ(plain.headers.count("content-encoding"), 0u);
    EXPECT_EQ(gz.headers.at("content-encoding"), "gzip");
    EXPECT_EQ(gz.headers.at("vary"), "Accept-Encoding");
    EXPECT_EQ(json::parse(rgbdcast::test::gunzip(gz.body)), json::parse(plain.body));
    EXPECT_LT(gz.body.size(), plain.body.size());
    EXPECT_EQ(raw_get(server.port(), "/v1/missions/floor/tileset.json",
                      "Accept-Encoding: gzip\r\nIf-None-Match: " + gz_tag + "\r\n")
                  .status,
              304);
    compared = true;
  }
  EXPECT_TRUE(compared) << "tileset.json changed between every two reads";
  expect_json_error(c->Get("/v1/missions/floor/tiles/0_0_0.v999999.glb"), 404, "an unknown tile");
  expect_json_error(c->Get("/v1/missions/floor/tileset.json?max-error=1e308"), 400, "a parameter");
  expect_json_error(c->Get("/v1/missions/nope/tileset.json"), 404, "an unknown mission");
  ASSERT_EQ(c->Delete("/v1/missions/floor")->status, 204);
  EXPECT_FALSE(fs::exists(test_dir.path + "/tiles/floor"));
}

// A mission's views are drawn from its tileset (tiles chosen by screen-space error) plus the keyframes the tileset
// does not hold yet; max-error=0 is full detail; the renderers keep what they load under --resident-mb.
TEST(Missions, ViewsDrawTheTilesetByScreenSpaceErrorUnderTheResidentCap) {
  REQUIRE_KEYFRAMES();
  const auto& k = keyframes();
  const TestDir test_dir("missions-tiled-views");
  ServerProcess server;
  std::string error;
  ASSERT_TRUE(server.start(test_dir.path, {"--renderers", "1", "--resident-mb", "16"}, &error)) << error;
  auto c = client(server.port());
  for (int i = 0; i < 4; ++i) ASSERT_EQ(post_keyframe(*c, "hall", i, k[static_cast<size_t>(i)])->status, 201);
  // At once, before the tile worker: the keyframes are drawn whole.
  auto early = c->Get("/v1/missions/hall/view?pose=capture&format=png");
  ASSERT_TRUE(early && early->status == 200) << (early ? early->body : "no answer");
  ASSERT_TRUE(wait_for_tileset(*c, "hall", 60.0));

  // The robot's view and an overview from high above, at the default error and at full detail.
  const std::string robot = "/v1/missions/hall/view?pose=capture&format=png";
  const std::string overview = "/v1/missions/hall/view?eye=0.5,-5,-2&target=0.5,0,1.5&fov=60&format=png";
  for (const std::string& view : {robot, overview}) {
    auto fine = c->Get((view + "&max-error=0").c_str());
    auto normal = c->Get(view.c_str());
    auto coarse = c->Get((view + "&max-error=64").c_str());
    ASSERT_TRUE(fine && normal && coarse);
    ASSERT_EQ(fine->status, 200) << fine->body;
    ASSERT_EQ(normal->status, 200) << normal->body;
    ASSERT_EQ(coarse->status, 200) << coarse->body;
    const int fine_tiles = std::stoi(fine->get_header_value("X-Tiles"));
    const int coarse_tiles = std::stoi(coarse->get_header_value("X-Tiles"));
    EXPECT_GE(fine_tiles, 1) << view;
    EXPECT_GE(fine_tiles, coarse_tiles) << view;
    EXPECT_EQ(fine->get_header_value("X-Pending-Keyframes"), "0");
    EXPECT_GT(covered(fine->body), 0.05) << view;
    const double db = psnr_db(normal->body, fine->body);
    const double coarse_db = psnr_db(coarse->body, fine->body);
    std::cout << view << ": tiles " << fine_tiles << " (max-error=0), " << normal->get_header_value("X-Tiles")
              << " (default), " << coarse_tiles << " (64 px); default vs full detail " << db
              << " dB, 64 px vs full detail " << coarse_db << " dB\n";
    EXPECT_GE(db, 32.0) << view;
    // The coarse tiles, seen from nearer than they are meant for, still show the scene (19.5 and 21.9 dB).
    EXPECT_GE(coarse_db, 16.0) << view;
  }
  // By default a view fits a renderer's share of the resident cap: its error is coarsened until its tiles fit, so the
  // same view again loads nothing (a view over the cap would load its parts again every time). A given max-error is
  // kept as given.
  for (const std::string& view : {robot, overview}) {
    auto first = c->Get(view.c_str());
    auto again = c->Get(view.c_str());
    auto given = c->Get((view + "&max-error=0.5").c_str());
    ASSERT_TRUE(first && again && given && first->status == 200 && again->status == 200 && given->status == 200);
    EXPECT_GE(std::stod(first->get_header_value("X-Max-Error")), 1.0) << view;
    EXPECT_EQ(again->get_header_value("X-Max-Error"), first->get_header_value("X-Max-Error")) << view;
    EXPECT_EQ(again->get_header_value("X-Parts-Loaded"), "0") << view;
    EXPECT_EQ(std::stod(given->get_header_value("X-Max-Error")), 0.5) << view;
    std::cout << view << ": default error " << first->get_header_value("X-Max-Error") << " px at a 16 MiB cap\n";
  }
  // The cap holds after every view, and the renderer keeps something resident.
  for (const char* eye : {"0,-0.3,-1.2", "2,-1,-2", "-1,-3,0", "0.5,-12,-3", "4,-0.5,6"}) {
    auto v =
        c->Get(("/v1/missions/hall/view?eye=" + std::string(eye) + "&target=0.5,0,1.5&fov=70&max-error=0").c_str());
    ASSERT_TRUE(v && v->status == 200) << eye;
    auto metrics = c->Get("/metrics");
    ASSERT_TRUE(metrics && metrics->status == 200);
    std::smatch m;
    ASSERT_TRUE(std::regex_search(metrics->body, m, std::regex("\nrgbdcast_resident_part_bytes ([0-9]+)")));
    const double bytes = std::stod(m[1]);
    EXPECT_LE(bytes, 16.0 * 1024 * 1024) << eye;
    EXPECT_GT(bytes, 0.0) << eye;
  }
  // Hostile max-error: each a 400 with a JSON body.
  for (const char* bad :
       {"max-error=-1", "max-error=1e308", "max-error=abc", "max-error=nan", "max-error=1&max-error=2", "max-error="})
    expect_json_error(c->Get(("/v1/missions/hall/view?" + std::string(bad)).c_str()), 400, bad);
  // A deleted mission's parts leave the renderer.
  ASSERT_EQ(c->Delete("/v1/missions/hall")->status, 204);
  bool released = false;
  for (int i = 0; i < 100 && !released; ++i) {
    auto metrics = c->Get("/metrics");
    ASSERT_TRUE(metrics);
    released = metrics->body.find("\nrgbdcast_resident_parts 0\n") != std::string::npos;
    if (!released) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_TRUE(released);
}

// A mission's JSON in pages (?after=SEQ&limit=N) with its totals; model.glb?max-error=M merged from the tiles and
// streamed from disk: M = 0 holds every triangle of the leaves, a large M fewer; hostile parameters are a 4xx with
// JSON. A mission longer than --max-model-keyframes has no in-memory model.glb: a 409 that names max-error=0.
TEST(Missions, TheJsonPagesAndTheTileExportIsBoundedByMaxError) {
  REQUIRE_KEYFRAMES();
  const auto& k = keyframes();
  const TestDir test_dir("missions-export");
  ServerProcess server;
  std::string error;
  ASSERT_TRUE(server.start(test_dir.path, {"--max-model-keyframes", "3"}, &error)) << error;
  auto c = client(server.port());
  for (int i = 0; i < 3; ++i) ASSERT_EQ(post_keyframe(*c, "long", i, k[static_cast<size_t>(i)])->status, 201);
  auto whole = c->Get("/v1/missions/long/model.glb");
  ASSERT_TRUE(whole);
  EXPECT_EQ(whole->status, 200) << whole->body.substr(0, 300);
  ASSERT_EQ(post_keyframe(*c, "long", 3, k[3])->status, 201);
  auto too_long = c->Get("/v1/missions/long/model.glb");
  expect_json_error(too_long, 409, "model.glb of 4 keyframes over --max-model-keyframes 3");
  EXPECT_NE(too_long->body.find("max-error=0"), std::string::npos) << too_long->body;

  const std::string all_text = c->Get("/v1/missions/long")->body;
  const json all = json::parse(all_text);
  ASSERT_TRUE(all.contains("keyframe_count")) << all_text.substr(0, 400);
  EXPECT_EQ(all["keyframe_count"], 4);
  EXPECT_EQ(all["keyframes"].size(), 4u);
  EXPECT_TRUE(all["next_after"].is_null());
  EXPECT_TRUE(all["after"].is_null());
  EXPECT_EQ(all["limit"], 100);
  size_t posted = 0;
  for (const auto& e : all["keyframes"]) posted += e["triangles"].get<size_t>();
  EXPECT_EQ(all["triangles"].get<size_t>(), posted);
  const json first = json::parse(c->Get("/v1/missions/long?limit=2")->body);
  ASSERT_EQ(first["keyframes"].size(), 2u);
  EXPECT_EQ(first["keyframes"][1]["seq"], 1);
  EXPECT_EQ(first["next_after"], 1);
  EXPECT_EQ(first["keyframe_count"], 4);
  EXPECT_EQ(first["bytes"], all["bytes"]);
  const json second = json::parse(c->Get("/v1/missions/long?after=1&limit=2")->body);
  ASSERT_EQ(second["keyframes"].size(), 2u);
  EXPECT_EQ(second["keyframes"][0]["seq"], 2);
  EXPECT_TRUE(second["next_after"].is_null());
  EXPECT_EQ(second["keyframes"][0], all["keyframes"][2]);
  EXPECT_TRUE(json::parse(c->Get("/v1/missions/long?after=3")->body)["keyframes"].empty());
  for (const char* bad : {"?limit=0", "?limit=1001", "?limit=x", "?after=-1", "?after=1e3", "?after=1&after=2",
                          "?page=2", "?after=99999999999"})
    expect_json_error(c->Get((std::string("/v1/missions/long") + bad).c_str()), 400, bad);

  // The full-detail export once the tileset holds every keyframe (built in the background): the triangles of its
  // leaves, the newest keyframe's whole and the older ones' less what newer ones saw again.
  std::function<void(const json&, std::vector<std::string>*)> leaf_uris = [&](const json& t,
                                                                              std::vector<std::string>* u) {
    if (t.contains("content") && t["content"]["uri"].get<std::string>().rfind("tiles/0_", 0) == 0)
      u->push_back(t["content"]["uri"]);
    for (const auto& ch : t.value("children", json::array())) leaf_uris(ch, u);
  };
  std::optional<httplib::Result> full_result;
  size_t full_triangles = 0, in_leaves = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < deadline) {
    auto ts = c->Get("/v1/missions/long/tileset.json");
    ASSERT_TRUE(ts && ts->status == 200);
    const json tileset = json::parse(ts->body);
    std::vector<std::string> uris;
    leaf_uris(tileset["root"], &uris);
    in_leaves = 0;
    bool newest = false, read = true;
    for (const auto& uri : uris) {
      newest = newest || uri.find("_3.v") != std::string::npos;
      auto r = c->Get(("/v1/missions/long/" + uri).c_str());
      if (!r || r->status != 200) {  // replaced meanwhile: look again
        read = false;
        break;
      }
      auto scene = rgbdcast::decode_glb(reinterpret_cast<const std::uint8_t*>(r->body.data()), r->body.size());
      ASSERT_TRUE(scene) << uri;
      in_leaves += scene->triangle_count();
    }
    full_result.emplace(c->Get("/v1/missions/long/model.glb?max-error=0"));
    httplib::Result& full = *full_result;
    ASSERT_TRUE(full);
    if (full->status == 200) {
      auto scene = rgbdcast::decode_glb(reinterpret_cast<const std::uint8_t*>(full->body.data()), full->body.size());
      ASSERT_TRUE(scene) << scene.error().message;
      full_triangles = scene->triangle_count();
      const bool same_version =
          full->get_header_value("ETag").find("-v" + tileset["asset"]["tilesetVersion"].get<std::string>() + "-") !=
          std::string::npos;
      if (newest && read && same_version) break;
    } else {
      EXPECT_EQ(full->status, 409) << full->body;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  ASSERT_GT(in_leaves, 0u);
  ASSERT_EQ(full_triangles, in_leaves);
  EXPECT_LE(full_triangles, posted);
  httplib::Result& full = *full_result;
  EXPECT_EQ(full->get_header_value("Content-Type"), "model/gltf-binary");
  EXPECT_EQ(full->get_header_value("Content-Length"), std::to_string(full->body.size()));
  EXPECT_NE(full->get_header_value("Content-Disposition").find("long-e0.glb"), std::string::npos);
  const std::string full_path = test_dir.path + "/full.glb";
  std::ofstream(full_path, std::ios::binary) << full->body;
  EXPECT_GLTF_VALID(full_path);

  // The coarse cut once the inner tiles are built (until then they are stale, and a cut goes through them to the
  // leaves).
  std::optional<httplib::Result> coarse_result;
  std::optional<rgbdcast::Result<rgbdcast::Scene>> coarse_decoded;
  const auto settle_deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  do {
    coarse_result.emplace(c->Get("/v1/missions/long/model.glb?max-error=10000"));
    ASSERT_TRUE(*coarse_result);
    ASSERT_EQ((*coarse_result)->status, 200) << (*coarse_result)->body;
    const std::string& body = (*coarse_result)->body;
    coarse_decoded.emplace(rgbdcast::decode_glb(reinterpret_cast<const std::uint8_t*>(body.data()), body.size()));
    ASSERT_TRUE(*coarse_decoded) << coarse_decoded->error().message;
    // Settled: no tile below the root without content (stale), the cut taken from that version.
    std::function<bool(const json&, bool)> fresh = [&](const json& t, bool root) {
      if (!root && !t.contains("content")) return false;
      for (const auto& ch : t.value("children", json::array()))
        if (!fresh(ch, false)) return false;
      return true;
    };
    auto ts = c->Get("/v1/missions/long/tileset.json");
    ASSERT_TRUE(ts && ts->status == 200);
    const json tileset = json::parse(ts->body);
    if (fresh(tileset["root"], true) &&
        (*coarse_result)
                ->get_header_value("ETag")
                .find("-v" + tileset["asset"]["tilesetVersion"].get<std::string>() + "-") != std::string::npos)
      break;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  } while (std::chrono::steady_clock::now() < settle_deadline);
  httplib::Result& coarse = *coarse_result;
  auto& coarse_scene = *coarse_decoded;
  EXPECT_GT(coarse_scene->triangle_count(), 0u);
  EXPECT_LT(coarse_scene->triangle_count(), full_triangles);
  EXPECT_LT(coarse->body.size(), full->body.size());
  EXPECT_LE(std::stoi(coarse->get_header_value("X-Tiles")), std::stoi(full->get_header_value("X-Tiles")));
  const std::string coarse_path = test_dir.path + "/coarse.glb";
  std::ofstream(coarse_path, std::ios::binary) << coarse->body;
  EXPECT_GLTF_VALID(coarse_path);
  std::printf(
      "export: %zu triangles posted; max-error=0 %zu bytes in %s tiles; max-error=10000 %zu bytes, %zu "
      "triangles in %s tiles; mission JSON %zu bytes, a page of 2 %zu bytes\n",
      posted, full->body.size(), full->get_header_value("X-Tiles").c_str(), coarse->body.size(),
      coarse_scene->triangle_count(), coarse->get_header_value("X-Tiles").c_str(),
      c->Get("/v1/missions/long")->body.size(), c->Get("/v1/missions/long?limit=2")->body.size());

  // The same tileset version and bound: 304 (the version of the settled tileset: a full export of it first).
  auto settled_full = c->Get("/v1/missions/long/model.glb?max-error=0");
  ASSERT_TRUE(settled_full);
  const std::string etag = settled_full->get_header_value("ETag");
  ASSERT_FALSE(etag.empty());
  auto again = c->Get("/v1/missions/long/model.glb?max-error=0", {{"If-None-Match", etag}});
  ASSERT_TRUE(again);
  EXPECT_EQ(again->status, 304);
  EXPECT_NE(coarse->get_header_value("ETag"), etag);

  for (const char* bad : {"?max-error=-1", "?max-error=1e308", "?max-error=10001", "?max-error=abc", "?max-error=nan",
                          "?max-error=inf", "?max-error=", "?max-error=1,2", "?max-error=1&max-error=2",
                          "?max-error=0&flavor=compat", "?max-error=0&detail=full"})
    expect_json_error(c->Get((std::string("/v1/missions/long/model.glb") + bad).c_str()), 400, bad);
  expect_json_error(c->Get("/v1/missions/nope/model.glb?max-error=0"), 404, "an unknown mission");
  expect_json_error(c->Get("/v1/missions/bad.name/model.glb?max-error=0"), 400, "a malformed name");
  expect_json_error(c->Get("/v1/missions/long/tiles/9_9_9.v1.glb"), 404, "an unknown tile");
}
