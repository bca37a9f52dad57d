// The request guard, the route table, image headers, path redaction and the job queue, without a server.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <future>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "service/http_errors.h"
#include "service/image_header.h"
#include "service/job_queue.h"
#include "service/request_guard.h"
#include "service/routes.h"

using namespace rgbdcast::service;

namespace {

GuardConfig loopback(std::string token = "") {
  return make_guard_config("127.0.0.1", 8080, {"http://robot.lan:9000"}, std::move(token), 1000);
}

RequestHead head(std::string method, std::string path,
                 std::vector<std::pair<std::string, std::string>> headers = {{"Host", "127.0.0.1:8080"}}) {
  return RequestHead{std::move(method), std::move(path), std::move(headers)};
}

int status_of(const RequestHead& h, const GuardConfig& g) {
  auto r = check_request(h, g);
  return r ? r->status : 0;
}

}  // namespace

TEST(Routes, LabelsAndAllowedMethods) {
  EXPECT_STREQ(match_route("/v1/scenes/abc/view").label, "/v1/scenes/{id}/view");
  EXPECT_STREQ(match_route("/v1/scenes/abc/model.glb").label, "/v1/scenes/{id}/model.glb");
  EXPECT_STREQ(match_route("/v1/scenes/abc").label, "/v1/scenes/{id}");
  EXPECT_STREQ(match_route("/v1/scenes").allow, "GET, HEAD, POST");
  EXPECT_FALSE(match_route("/v1/scenes/").known);
  EXPECT_FALSE(match_route("/v1/scenes/a/b").known);
  EXPECT_FALSE(match_route("/nope").known);
  EXPECT_TRUE(match_route("/v1/scenes/x").allows("DELETE"));
  EXPECT_FALSE(match_route("/v1/scenes/x/view").allows("DELETE"));
  EXPECT_FALSE(match_route("/healthz").allows("GE"));  // whole names only
  // Live missions.
  EXPECT_STREQ(match_route("/v1/missions").allow, "GET, HEAD");
  EXPECT_STREQ(match_route("/v1/missions/robot-1").allow, "GET, HEAD, DELETE");
  EXPECT_STREQ(match_route("/v1/missions/robot-1/keyframes").allow, "POST");
  EXPECT_STREQ(match_route("/v1/missions/robot-1/events").label, "/v1/missions/{name}/events");
  EXPECT_STREQ(match_route("/v1/missions/robot-1/events").allow, "GET");
  EXPECT_STREQ(match_route("/v1/missions/robot-1/view").allow, "GET, HEAD, POST");
  EXPECT_STREQ(match_route("/v1/missions/robot-1/model.glb").allow, "GET, HEAD");
  EXPECT_FALSE(match_route("/v1/missions/").known);
  EXPECT_FALSE(match_route("/v1/missions/a/b").known);
}

TEST(RequestGuard, HostAndOrigin) {
  const GuardConfig g = loopback();
  EXPECT_EQ(status_of(head("GET", "/healthz"), g), 0);
  EXPECT_EQ(status_of(head("GET", "/healthz", {{"host", "LOCALHOST:8080"}}), g), 0);
  EXPECT_EQ(status_of(head("GET", "/healthz", {{"Host", "robot.lan:9000"}}), g), 0);  // host of an allowed origin
  EXPECT_EQ(status_of(head("GET", "/healthz", {}), g), 400);
  EXPECT_EQ(status_of(head("GET", "/healthz", {{"Host", "127.0.0.1:8080"}, {"Host", "127.0.0.1:8080"}}), g), 400);
  EXPECT_EQ(status_of(head("GET", "/healthz", {{"Host", "evil.example:8080"}}), g), 403);
  EXPECT_EQ(status_of(head("GET", "/healthz", {{"Host", "127.0.0.1:8081"}}), g), 403);
  EXPECT_EQ(status_of(head("GET", "/healthz", {{"Host", "127.0.0.1:8080"}, {"Origin", "http://evil.example"}}), g),
            403);
  EXPECT_EQ(status_of(head("GET", "/healthz", {{"Host", "127.0.0.1:8080"}, {"Origin", "null"}}), g), 403);
  EXPECT_EQ(status_of(head("GET", "/healthz", {{"Host", "127.0.0.1:8080"}, {"Origin", "http://127.0.0.1:8080"}}), g),
            0);
  EXPECT_EQ(status_of(head("GET", "/healthz", {{"Host", "127.0.0.1:8080"}, {"Origin", "http://robot.lan:9000"}}), g),
            0);
}

TEST(RequestGuard, MethodsTokenAndBodies) {
  const GuardConfig g = loopback("s3cret-token-0123456789");
  auto r = check_request(head("PUT", "/v1/scenes"), g);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 405);
  EXPECT_EQ(r->allow, "GET, HEAD, POST");
  EXPECT_EQ(status_of(head("POST", "/v1/scenes"), g), 401);
  EXPECT_EQ(status_of(head("DELETE", "/v1/scenes/x"), g), 401);
  EXPECT_EQ(status_of(head("GET", "/v1/scenes"), g), 0);  // reads need no token
  auto with = [](std::vector<std::pair<std::string, std::string>> extra) {
    std::vector<std::pair<std::string, std::string>> h = {{"Host", "127.0.0.1:8080"},
                                                          {"Authorization", "Bearer s3cret-token-0123456789"}};
    h.insert(h.end(), extra.begin(), extra.end());
    return h;
  };
  EXPECT_EQ(status_of(head("POST", "/v1/scenes", with({})), g), 0);
  EXPECT_EQ(status_of(head("POST", "/v1/scenes", {{"Host", "127.0.0.1:8080"}, {"Authorization", "Bearer s3cret"}}), g),
            401);
  EXPECT_EQ(status_of(head("POST", "/v1/scenes", with({{"Content-Length", "999"}})), g), 0);
  EXPECT_EQ(status_of(head("POST", "/v1/scenes", with({{"Content-Length", "1001"}})), g), 413);
  EXPECT_EQ(status_of(head("POST", "/v1/scenes", with({{"Content-Length", "10737418240"}})), g), 413);
  EXPECT_EQ(status_of(head("POST", "/v1/scenes", with({{"Content-Length", "-5"}})), g), 400);
  EXPECT_EQ(status_of(head("POST", "/v1/scenes", with({{"Content-Length", "abc"}})), g), 400);
  EXPECT_EQ(status_of(head("POST", "/v1/scenes", with({{"Content-Length", "5"}, {"Content-Length", "5"}})), g), 400);
  EXPECT_EQ(status_of(head("POST", "/v1/scenes", with({{"Content-Length", "99999999999999999999"}})), g), 400);
  EXPECT_EQ(status_of(head("POST", "/v1/scenes", with({{"Content-Length", "5"}, {"Transfer-Encoding", "chunked"}})), g),
            400);
  EXPECT_EQ(status_of(head("POST", "/v1/scenes", with({{"Transfer-Encoding", "gzip, chunked"}})), g), 400);
  EXPECT_EQ(status_of(head("POST", "/v1/scenes", with({{"Transfer-Encoding", "chunked"}})), g), 0);
  EXPECT_EQ(status_of(head("POST", "/v1/scenes", with({{"Content-Encoding", "gzip"}})), g), 0);
  EXPECT_EQ(status_of(head("POST", "/v1/scenes", with({{"Content-Encoding", "zstd"}})), g), 415);
  EXPECT_EQ(status_of(head("GET", "/v1/scenes", {{"Host", "127.0.0.1:8080"}, {"Content-Length", "3"}}), g), 400);
  EXPECT_EQ(status_of(head("GET", "/v1/scenes", {{"Host", "127.0.0.1:8080"}, {"Content-Length", "0"}}), g), 0);
}

TEST(RequestGuard, LoopbackAndConstantTimeCompare) {
  EXPECT_TRUE(is_loopback_address("127.0.0.1"));
  EXPECT_TRUE(is_loopback_address("127.1.2.3"));
  EXPECT_TRUE(is_loopback_address("::1"));
  EXPECT_FALSE(is_loopback_address("0.0.0.0"));
  EXPECT_FALSE(is_loopback_address("192.168.1.4"));
  EXPECT_TRUE(constant_time_equal("abc", "abc"));
  EXPECT_FALSE(constant_time_equal("abc", "abd"));
  EXPECT_FALSE(constant_time_equal("abc", "abcd"));
  EXPECT_FALSE(constant_time_equal("", "a"));
  // Every own name of a wildcard bind: at least loopback and localhost.
  const GuardConfig any = make_guard_config("0.0.0.0", 9, {}, "", 1000);
  EXPECT_NE(std::find(any.hosts.begin(), any.hosts.end(), "127.0.0.1:9"), any.hosts.end());
  EXPECT_NE(std::find(any.hosts.begin(), any.hosts.end(), "localhost:9"), any.hosts.end());
}

TEST(ImageHeader, PngAndJpegSizesWithoutDecoding) {
  for (const char* ext : {".png", ".jpg"}) {
    cv::Mat img(37, 53, CV_8UC3, cv::Scalar(10, 20, 30));
    std::vector<uchar> bytes;
    ASSERT_TRUE(cv::imencode(ext, img, bytes));
    auto size = peek_image_size(bytes.data(), bytes.size());
    ASSERT_TRUE(size) << ext << ": " << size.error().message;
    EXPECT_EQ(size->width, 53) << ext;
    EXPECT_EQ(size->height, 37) << ext;
    for (size_t cut : {size_t{0}, size_t{3}, size_t{10}, size_t{20}})
      EXPECT_FALSE(peek_image_size(bytes.data(), cut)) << ext << " cut at " << cut;
  }
  const unsigned char bmp[] = {'B', 'M', 0, 0, 0, 0, 0, 0, 0, 0};
  EXPECT_FALSE(peek_image_size(bmp, sizeof bmp));
}

TEST(HttpErrors, PathsAreRedacted) {
  EXPECT_EQ(redact_paths("cannot create /home/u/store/scenes/.tmp-intrinsics-ab.json: Permission denied"),
            "cannot create <path>: Permission denied");
  EXPECT_EQ(redact_paths("File size mismatch : /etc/hostname, requestedBytes 1"),
            "File size mismatch : <path>, requestedBytes 1");
  EXPECT_EQ(redact_paths("parameter 'fov': must be between 1 and 179 degrees"),
            "parameter 'fov': must be between 1 and 179 degrees");
  EXPECT_EQ(redact_paths("a/b and /single stay"), "a/b and /single stay");
}

TEST(JobQueue, BoundedAndSurvivesThrowingJobs) {
  JobQueue q(1, 1);
  std::promise<void> gate;
  std::shared_future<void> open = gate.get_future().share();
  std::atomic<int> done{0};
  EXPECT_TRUE(q.try_submit([open, &done] {
    open.wait();
    ++done;
  }));
  while (q.running() == 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  EXPECT_TRUE(q.try_submit([&done] {
    ++done;
    throw std::runtime_error("boom");
  }));
  EXPECT_FALSE(q.try_submit([&done] { ++done; }));  // one running, one waiting: full
  EXPECT_EQ(q.rejected(), 1u);
  gate.set_value();
  while (done < 2) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  EXPECT_TRUE(q.try_submit([&done] { ++done; }));  // the worker survived the throw
  while (done < 3) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  EXPECT_EQ(done, 3);
}
