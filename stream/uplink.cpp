#include "stream/uplink.h"

#include <httplib.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>

namespace rgbdcast::stream {

struct Uplink::Impl {
  explicit Impl(const UplinkOptions& o) : options(o), client(o.server_url) {
    client.set_keep_alive(true);
    // No Nagle: httplib writes a request's headers and its body separately, and the body's last partial segment
    // would wait for the acknowledgement of what is ahead of it, which the server delays (service/connection_gate.cpp).
    client.set_tcp_nodelay(true);
    const auto connect_us = static_cast<time_t>(o.connect_timeout_s * 1e6);
    client.set_connection_timeout(connect_us / 1000000, connect_us % 1000000);
    if (!o.token.empty()) client.set_bearer_token_auth(o.token);
  }
  void set_io_timeout(double s) {
    const auto us = static_cast<time_t>(s * 1e6);
    client.set_read_timeout(us / 1000000, us % 1000000);
    client.set_write_timeout(us / 1000000, us % 1000000);
  }
  UplinkOptions options;
  httplib::Client client;
};

Uplink::Uplink(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Uplink::~Uplink() = default;

Result<std::unique_ptr<Uplink>> Uplink::create(const UplinkOptions& options) {
  static const std::regex url(R"(^https?://[A-Za-z0-9.\-]+(:[0-9]{1,5})?/?$)");
  if (!std::regex_match(options.server_url, url))
    return make_error(ErrorCode::kInvalidArgument,
                      "--server must be http://host:port (got '" + options.server_url + "')");
  UplinkOptions o = options;
  if (o.server_url.back() == '/') o.server_url.pop_back();
  auto impl = std::make_unique<Impl>(o);
  if (!impl->client.is_valid())
    return make_error(ErrorCode::kInvalidArgument, "--server '" + o.server_url + "' cannot be used");
  return std::unique_ptr<Uplink>(new Uplink(std::move(impl)));
}

Status Uplink::check_reachable() {
  auto seconds = round_trip_s();
  if (!seconds) return seconds.error();
  return ok_status();
}

Result<double> Uplink::round_trip_s() {
  impl_->set_io_timeout(5);
  const auto t0 = std::chrono::steady_clock::now();
  auto res = impl_->client.Get("/healthz");
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!res)
    return make_error(ErrorCode::kUnavailable,
                      "cannot reach " + impl_->options.server_url + ": " + httplib::to_string(res.error()));
  return seconds;
}

namespace {

std::string error_line(int status, const std::string& body) {
  auto j = nlohmann::json::parse(body, nullptr, false);
  std::string what = "HTTP " + std::to_string(status);
  if (j.is_object() && j.contains("error") && j["error"].is_string()) what += " " + j["error"].get<std::string>();
  if (j.is_object() && j.contains("message") && j["message"].is_string())
    what += ": " + j["message"].get<std::string>();
  return what;
}

}  // namespace

PostResult Uplink::post_keyframe(const std::string& mission, const OutboxEntry& e, const std::vector<std::uint8_t>& glb,
                                 double io_timeout_s, const ChunkGate& gate) {
  impl_->set_io_timeout(io_timeout_s);
  char captured[32];
  std::snprintf(captured, sizeof captured, "%.6f", e.captured);
  const std::string target = "/v1/missions/" + mission + "/keyframes?seq=" + std::to_string(e.seq) +
                             "&pose=" + pose_query(e.pose) + "&captured=" + captured +
                             (e.rev > 0 ? "&rev=" + std::to_string(e.rev) : std::string());
  const auto t0 = std::chrono::steady_clock::now();
  const char* body = reinterpret_cast<const char*>(glb.data());
  auto res = gate ? impl_->client.Post(
                        target.c_str(), httplib::Headers{}, glb.size(),
                        [&](size_t offset, size_t length, httplib::DataSink& sink) {
                          const size_t n = std::min(length, kBodyChunkBytes);
                          return gate(offset, n) && sink.write(body + offset, n);
                        },
                        "model/gltf-binary")
                  : impl_->client.Post(target.c_str(), body, glb.size(), "model/gltf-binary");
  PostResult out;
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!res) {
    out.outcome = PostOutcome::kRetry;
    out.error = "no answer: " + httplib::to_string(res.error());
    return out;
  }
  out.status = res->status;
  out.body = res->body;
  if (res->status == 200 || res->status == 201) {
    out.outcome = PostOutcome::kStored;
    return out;
  }
  out.error = error_line(res->status, res->body);
  if (res->has_header("Retry-After")) {
    try {
      out.retry_after_s = std::stod(res->get_header_value("Retry-After"));
    } catch (...) {
      out.retry_after_s = -1;
    }
  }
  if (res->status == 409)
    out.outcome = PostOutcome::kConflict;
  else if (res->status == 401 || res->status == 403)
    out.outcome = PostOutcome::kFatal;
  else if (res->status >= 500 || res->status == 429 || res->status == 408)
    out.outcome = PostOutcome::kRetry;
  else
    out.outcome = PostOutcome::kRejected;
  return out;
}

Result<std::string> Uplink::get_mission(const std::string& mission) {
  impl_->set_io_timeout(10);
  auto res = impl_->client.Get(("/v1/missions/" + mission).c_str());
  if (!res) return make_error(ErrorCode::kUnavailable, "GET mission: " + httplib::to_string(res.error()));
  if (res->status == 404) return make_error(ErrorCode::kNotFound, "mission '" + mission + "' is not on the server");
  if (res->status != 200)
    return make_error(ErrorCode::kUnavailable, "GET mission: " + error_line(res->status, res->body));
  return res->body;
}

Result<std::string> read_token_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) return make_error(ErrorCode::kNotFound, "cannot read token file " + path);
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  const auto first = text.find_first_not_of(" \t\r\n");
  if (first == std::string::npos) return make_error(ErrorCode::kInvalidInput, "token file " + path + " is empty");
  const std::string token = text.substr(first, text.find_last_not_of(" \t\r\n") - first + 1);
  for (unsigned char c : token)
    if (c < 0x21 || c > 0x7e)
      return make_error(ErrorCode::kInvalidInput,
                        "token file " + path + " must hold one token, without spaces or control characters");
  return token;
}

}  // namespace rgbdcast::stream
