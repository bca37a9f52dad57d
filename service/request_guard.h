#pragma once
// The checks every request passes once its headers are read and before its body is, in this order:
// 1. Host is one of the server's own names (or the host of an allowed origin), and Origin, when sent, is the
//    server's own or allowed: 403 otherwise (DNS rebinding and cross-site requests). A missing Host is 400.
// 2. The method is one the route allows: 405 with Allow.
// 3. Writes (POST, DELETE) carry "Authorization: Bearer <token>" when a token is configured: 401 otherwise. The
//    token is compared in constant time.
// 4. Body framing: at most one Content-Length, all digits; not both Content-Length and Transfer-Encoding; only
//    "chunked" as transfer coding; no body on GET, HEAD and DELETE: 400. A declared length over the limit: 413.
//    Content-Encoding other than identity, gzip, deflate or br: 415 (the inflated bytes count against the limit).
// No I/O, no HTTP library: the caller gives the request head and answers the refusal.
#include <cstddef>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace rgbdcast::service {

struct RequestHead {
  std::string method, path;
  std::vector<std::pair<std::string, std::string>> headers;  // names in any case, in arrival order
};

struct Refusal {
  int status = 400;
  std::string detail;
  std::string allow;              // 405: the Allow header
  bool www_authenticate = false;  // 401: send WWW-Authenticate: Bearer
};

struct GuardConfig {
  std::vector<std::string> hosts;    // accepted Host values, lower case, "host:port"
  std::vector<std::string> origins;  // accepted Origin values, lower case, "http://host:port"
  std::string token;                 // empty: writes need no token
  size_t max_body_bytes = 64u << 20;
};

// Own names of a server bound to `bind` on `port`: the bind address; for a loopback bind also 127.0.0.1, localhost
// and [::1]; for 0.0.0.0 or :: every local interface address, localhost and the host name. `allow_origins` are
// origins like "http://robot.lan:8080" (their host:port is accepted as a Host too).
GuardConfig make_guard_config(const std::string& bind, int port, const std::vector<std::string>& allow_origins,
                              std::string token, size_t max_body_bytes);

bool is_loopback_address(const std::string& bind);
// Equal strings, in time that depends on the lengths only.
bool constant_time_equal(const std::string& a, const std::string& b);

std::optional<Refusal> check_request(const RequestHead& head, const GuardConfig& config);

}  // namespace rgbdcast::service
