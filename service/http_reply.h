#pragma once
// Small pieces every route file of the service uses to answer (view_service.cpp, mission_routes.cpp): the JSON
// error and value bodies, the 503 with Retry-After, the media type of a request, a refused body, upload slots.
// httplib.h must be compiled with the library's flags (../shared/STACK.md).
#include <httplib.h>

#include <atomic>
#include <cctype>
#include <string>

#include <nlohmann/json.hpp>

#include "scene/result.h"
#include "service/connection_gate.h"
#include "service/http_errors.h"
#include "service/upload_body.h"

namespace rgbdcast::service {

inline void send_error(httplib::Response& res, int status, const std::string& detail) {
  res.status = status;
  res.set_content(error_body(status, detail), "application/json");
}

// Errors from the library may quote server paths: they are taken out.
inline void send_error(httplib::Response& res, const Error& e) {
  const int status = http_status_for(e.code);
  if (status == 503) res.set_header("Retry-After", "1");
  send_error(res, status, redact_paths(e.message));
}

inline void send_json(httplib::Response& res, int status, const nlohmann::json& body) {
  res.status = status;
  res.set_content(body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n", "application/json");
}

// Sets the strong ETag and answers 304 when If-None-Match names it (or is "*"): true when answered, and the caller
// sends nothing more.
inline bool answer_not_modified(const httplib::Request& req, httplib::Response& res, const std::string& etag) {
  res.set_header("ETag", etag);
  const std::string inm = req.get_header_value("If-None-Match");
  if (inm.empty() || (inm != "*" && inm.find(etag) == std::string::npos)) return false;
  res.status = 304;
  return true;
}

// 503 for a full queue.
inline void send_busy(httplib::Response& res, const std::string& detail, int retry_after_s) {
  res.set_header("Retry-After", std::to_string(retry_after_s));
  send_error(res, 503, detail);
}

// The media type without parameters, lower case.
inline std::string media_type(const std::string& content_type) {
  std::string t = content_type.substr(0, content_type.find(';'));
  while (!t.empty() && t.back() == ' ') t.pop_back();
  for (auto& c : t) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return t;
}

// The answer to a body that is not processed (service/upload_body.h): its 4xx, and the connection closed when the
// body was not read to its end. A body that could not be read because it stopped arriving (a read timed out: an
// outage, or under the minimum rate) is a 408, which a client retries, not a 400 about bytes never received.
inline void send_refusal(httplib::Response& res, const BodyRefusal& refusal) {
  if (refusal.close) GatedServer::close_after_response();
  if (refusal.status == 400 && GatedServer::request_read_failed())
    return send_error(res, 408, "request body not received in time (it stopped arriving)");
  send_error(res, refusal.status, refusal.detail);
}

// Counts requests holding a slot; try_acquire fails when `limit` already do.
class Slots {
 public:
  explicit Slots(int limit) : limit_(limit) {}
  bool try_acquire() {
    int n = used_.load();
    do {
      if (n >= limit_) return false;
    } while (!used_.compare_exchange_weak(n, n + 1));
    return true;
  }
  void release() { --used_; }
  int used() const { return used_.load(); }

 private:
  const int limit_;
  std::atomic<int> used_{0};
};

// Releases a slot when it goes out of scope.
struct SlotRelease {
  Slots* slots;
  ~SlotRelease() { slots->release(); }
};

}  // namespace rgbdcast::service
