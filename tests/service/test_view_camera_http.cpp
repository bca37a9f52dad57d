// The view route's full camera over real HTTP: camera= as a query parameter and the camera JSON as a POST
// body both reproduce pose=capture byte for byte when they state the capture camera; bad cameras are 400 with a JSON
// error body.
#include <httplib.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "tests/common/test_data.h"
#include "tests/service/server_process.h"

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr const char* kFr1 = "tum/rgbd_dataset_freiburg1_xyz";

// The camera JSON of a scene's capture camera, from what GET /v1/scenes/{id} says about it.
std::string capture_camera_json(const json& scene) {
  const json& c = scene.at("capture_camera");
  json pose = json::array();
  for (int r = 0; r < 4; ++r) {
    json row = json::array();
    for (int col = 0; col < 4; ++col) row.push_back(c.at("camera_to_world")[r * 4 + col]);
    pose.push_back(row);
  }
  return json{{"fx", c["fx"]},       {"fy", c["fy"]},         {"cx", c["cx"]}, {"cy", c["cy"]},
              {"width", c["width"]}, {"height", c["height"]}, {"pose", pose}}
      .dump();
}

void expect_400(const httplib::Result& r, const std::string& detail) {
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400) << r->body;
  const json body = json::parse(r->body, nullptr, false);
  ASSERT_TRUE(body.is_object()) << r->body;
  EXPECT_NE(body.value("detail", "").find(detail), std::string::npos) << "expected \"" << detail << "\" in " << r->body;
}

TEST(ServiceViewCamera, CameraParameterAndPostBodyReproduceTheCaptureView) {
  REQUIRE_DATA(kFr1);
  const std::string data_dir = rgbdcast::test::temp_dir("service-camera");
  rgbdcast::test::ServerProcess server;
  std::string error;
  ASSERT_TRUE(server.start(data_dir, {}, &error)) << error;
  httplib::Client c("127.0.0.1", server.port());
  c.set_read_timeout(180, 0);
  const auto f = rgbdcast::test::fr1_frame0();
  auto up = c.Post("/v1/scenes", httplib::MultipartFormDataItems{
                                     {"color", f.color, "color.png", "image/png"},
                                     {"depth", f.depth, "depth.png", "image/png"},
                                     {"intrinsics", f.intrinsics_json, "intrinsics.json", "application/json"}});
  ASSERT_TRUE(up && up->status == 201) << (up ? up->body : "no response");
  const std::string id = json::parse(up->body).at("id");
  auto meta = c.Get(("/v1/scenes/" + id).c_str());
  ASSERT_TRUE(meta && meta->status == 200);
  const std::string cam = capture_camera_json(json::parse(meta->body));
  const std::string view = "/v1/scenes/" + id + "/view";

  auto capture = c.Get(view.c_str(), httplib::Params{{"pose", "capture"}, {"format", "png"}}, httplib::Headers{});
  auto query = c.Get(view.c_str(), httplib::Params{{"camera", cam}, {"format", "png"}}, httplib::Headers{});
  auto post = c.Post((view + "?format=png").c_str(), cam, "application/json");
  ASSERT_TRUE(capture && query && post);
  ASSERT_EQ(capture->status, 200) << capture->body;
  ASSERT_EQ(query->status, 200) << query->body;
  ASSERT_EQ(post->status, 200) << post->body;
  EXPECT_EQ(query->body, capture->body) << "camera= gives the pose=capture image, byte for byte";
  EXPECT_EQ(post->body, capture->body) << "the POST body gives the pose=capture image, byte for byte";
  const cv::Mat png =
      cv::imdecode(std::vector<unsigned char>(capture->body.begin(), capture->body.end()), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(png.cols, 640);
  ASSERT_EQ(png.rows, 480);
  std::vector<cv::Mat> ch;
  cv::split(png, ch);
  ASSERT_EQ(ch.size(), 4u);
  EXPECT_GT(cv::countNonZero(ch[3]), 150000) << "not a blank view";

  expect_400(c.Post(view.c_str(), std::string("{\"fx\": 1"), "application/json"), "parameter 'camera': not valid JSON");
  expect_400(c.Post((view + "?pose=capture").c_str(), cam, "application/json"), "a full camera excludes pose");
  expect_400(c.Get(view.c_str(), httplib::Params{{"camera", cam}, {"width", "320"}}, httplib::Headers{}),
             "a full camera excludes width");
  json scaled = json::parse(cam);
  scaled["pose"][0][0] = 2.0;
  expect_400(c.Post(view.c_str(), scaled.dump(), "application/json"), "'pose' rotation is not a rotation");
  json big = json::parse(cam);
  big["width"] = 5000;
  expect_400(c.Post(view.c_str(), big.dump(), "application/json"), "'width' must be 1..4096");
  server.stop();
  fs::remove_all(data_dir);
}

}  // namespace
