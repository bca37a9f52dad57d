// The real `rgbdcast serve` against GLB attacks, over loopback HTTP: URIs naming server files (buffer and
// image), JSON nested 15,000 and 20,000 levels deep, an accessor claiming 2^26 elements and a zero-filled one. Each
// gets a 422 JSON error that names the problem without server paths, nothing is stored, the server stays up, and its
// peak RSS (VmHWM) does not grow for what the files only claim.
#include <httplib.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "tests/common/test_data.h"
#include "tests/gltf/hostile_glbs.h"
#include "tests/service/server_process.h"

namespace fs = std::filesystem;
using nlohmann::json;
using rgbdcast::test::Bytes;
using rgbdcast::test::ServerProcess;

namespace {

// Peak resident set of a process, from /proc (kB).
long vm_hwm_kb(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string key;
  long value = -1;
  while (in >> key) {
    if (key == "VmHWM:") {
      in >> value;
      return value;
    }
    in.ignore(1 << 20, '\n');
  }
  return -1;
}

class HostileGlb : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    data_dir_ = rgbdcast::test::temp_dir("service-hostile-glb");
    server_ = std::make_unique<ServerProcess>();
    server_->start(data_dir_, {}, &start_error_);
  }
  static void TearDownTestSuite() {
    if (server_ && server_->running()) server_->stop();
    server_.reset();
    fs::remove_all(data_dir_);
  }
  void SetUp() override {
    ASSERT_TRUE(start_error_.empty()) << start_error_;
    c_ = std::make_unique<httplib::Client>("127.0.0.1", server_->port());
    c_->set_connection_timeout(5, 0);
    c_->set_read_timeout(60, 0);
  }

  size_t scene_count() {
    auto r = c_->Get("/v1/scenes");
    return r && r->status == 200 ? json::parse(r->body)["scenes"].size() : size_t(-1);
  }

  // POSTs the GLB and expects a 422 whose detail holds `needle` and none of `secrets`; the server answers /healthz
  // afterwards and has stored nothing.
  void expect_refused(const Bytes& glb, const std::string& needle, const std::vector<std::string>& secrets = {}) {
    const size_t before = scene_count();
    auto r = c_->Post("/v1/scenes", std::string(glb.begin(), glb.end()), "model/gltf-binary");
    ASSERT_TRUE(r) << needle << ": no response (" << httplib::to_string(r.error()) << ")";
    EXPECT_EQ(r->status, 422) << r->body;
    EXPECT_NE(r->get_header_value("Content-Type").find("application/json"), std::string::npos);
    const json body = json::parse(r->body, nullptr, false);
    ASSERT_TRUE(body.is_object() && body.contains("detail")) << r->body;
    const std::string detail = body["detail"].get<std::string>();
    EXPECT_NE(detail.find(needle), std::string::npos) << detail;
    for (const auto& s : secrets) EXPECT_EQ(r->body.find(s), std::string::npos) << "leaks '" << s << "': " << r->body;
    EXPECT_EQ(r->body.find(data_dir_), std::string::npos) << "leaks the store's path: " << r->body;
    auto h = c_->Get("/healthz");
    ASSERT_TRUE(h) << "the server died on: " << needle;
    EXPECT_EQ(h->status, 200);
    EXPECT_EQ(scene_count(), before) << "a refused GLB was stored";
  }

  static inline std::unique_ptr<ServerProcess> server_;
  static inline std::string data_dir_, start_error_;
  std::unique_ptr<httplib::Client> c_;
};

TEST_F(HostileGlb, TheSampleItselfIsAccepted) {
  const Bytes glb = rgbdcast::test::plain_sample_glb();
  auto r = c_->Post("/v1/scenes", std::string(glb.begin(), glb.end()), "model/gltf-binary");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 201) << r->body;
  const json s = json::parse(r->body);
  EXPECT_EQ(s["vertices"].get<int>(), 49 + 25 + 24) << r->body;
  EXPECT_EQ(s["triangles"].get<int>(), 72 + 32 + 8) << r->body;
  ASSERT_TRUE(c_->Delete(("/v1/scenes/" + s["id"].get<std::string>()).c_str()));
}

TEST_F(HostileGlb, BufferUriNamingAServerFileIsRefused) {
  expect_refused(rgbdcast::test::glb_with_buffer_uri("/etc/hostname"), "external URI not allowed (buffers[0].uri)",
                 {"/etc/hostname", "File size mismatch", "requestedBytes"});
  expect_refused(rgbdcast::test::glb_with_buffer_uri("../../../../../../etc/hostname"), "external URI not allowed",
                 {"hostname"});
}

TEST_F(HostileGlb, ImageUriNamingAServerFileIsRefused) {
  expect_refused(rgbdcast::test::glb_with_image_uri("/etc/hostname"), "external URI not allowed (images[0].uri)",
                 {"/etc/hostname"});
}

TEST_F(HostileGlb, DeeplyNestedExtrasAreA422NotACrash) {
  for (int depth : {15000, 20000}) {
    const Bytes glb = rgbdcast::test::glb_with_nested_extras(depth);
    EXPECT_GT(glb.size(), 6u * depth);  // {"a": and } per level: 99 kB at 15,000
    expect_refused(glb, "JSON nested deeper than 64 levels");
  }
}

TEST_F(HostileGlb, ClaimedElementsCostNoMemory) {
  const long before = vm_hwm_kb(server_->pid());
  ASSERT_GT(before, 0);
  for (int i = 0; i < 4; ++i) {  // the probe sent 4 in parallel for 6.46 GB; in sequence each was +1.57 GB
    expect_refused(rgbdcast::test::glb_with_position_count(std::uint64_t(1) << 26), "do not fit in its bufferView");
    expect_refused(rgbdcast::test::glb_without_bufferview(std::uint64_t(1) << 26), "has no bufferView");
  }
  const long after = vm_hwm_kb(server_->pid());
  std::printf("server VmHWM %ld kB -> %ld kB over 8 hostile GLBs\n", before, after);
  EXPECT_LT(after - before, 50 * 1024);
}

}  // namespace
