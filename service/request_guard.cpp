#include "service/request_guard.h"

#include <arpa/inet.h>
#include <ifaddrs.h>
#include <netinet/in.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>

#include "service/routes.h"

namespace rgbdcast::service {
namespace {

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool iequals(const std::string& a, const char* b) { return lower(a) == lower(b); }

std::vector<const std::string*> values_of(const RequestHead& head, const char* name) {
  std::vector<const std::string*> out;
  for (const auto& [n, v] : head.headers)
    if (iequals(n, name)) out.push_back(&v);
  return out;
}

std::string host_port(const std::string& host, int port) {
  const bool v6 = host.find(':') != std::string::npos;
  return lower((v6 ? "[" + host + "]" : host) + ":" + std::to_string(port));
}

void add_unique(std::vector<std::string>& list, std::string s) {
  if (std::find(list.begin(), list.end(), s) == list.end()) list.push_back(std::move(s));
}

std::vector<std::string> interface_addresses() {
  std::vector<std::string> out;
  ifaddrs* list = nullptr;
  if (::getifaddrs(&list) != 0) return out;
  for (ifaddrs* a = list; a; a = a->ifa_next) {
    if (!a->ifa_addr) continue;
    char buf[INET6_ADDRSTRLEN] = {0};
    if (a->ifa_addr->sa_family == AF_INET)
      ::inet_ntop(AF_INET, &reinterpret_cast<sockaddr_in*>(a->ifa_addr)->sin_addr, buf, sizeof buf);
    else if (a->ifa_addr->sa_family == AF_INET6)
      ::inet_ntop(AF_INET6, &reinterpret_cast<sockaddr_in6*>(a->ifa_addr)->sin6_addr, buf, sizeof buf);
    if (buf[0]) out.push_back(buf);
  }
  ::freeifaddrs(list);
  return out;
}

std::string trim(const std::string& s) {
  size_t b = 0, e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return s.substr(b, e - b);
}

Refusal refuse(int status, std::string detail) { return Refusal{status, std::move(detail), "", false}; }

}  // namespace

bool is_loopback_address(const std::string& bind) {
  if (bind == "localhost" || bind == "::1") return true;
  in_addr a{};
  return ::inet_pton(AF_INET, bind.c_str(), &a) == 1 && (ntohl(a.s_addr) >> 24) == 127;
}

bool constant_time_equal(const std::string& a, const std::string& b) {
  const size_t n = std::max(a.size(), b.size());
  unsigned diff = a.size() == b.size() ? 0u : 1u;
  for (size_t i = 0; i < n; ++i) {
    const unsigned char x = i < a.size() ? static_cast<unsigned char>(a[i]) : 0;
    const unsigned char y = i < b.size() ? static_cast<unsigned char>(b[i]) : 0;
    diff |= static_cast<unsigned>(x ^ y);
  }
  return diff == 0;
}

GuardConfig make_guard_config(const std::string& bind, int port, const std::vector<std::string>& allow_origins,
                              std::string token, size_t max_body_bytes) {
  GuardConfig g;
  g.token = std::move(token);
  g.max_body_bytes = max_body_bytes;
  std::vector<std::string> names = {bind};
  if (is_loopback_address(bind)) {
    names.insert(names.end(), {"127.0.0.1", "localhost", "::1"});
  } else if (bind == "0.0.0.0" || bind == "::") {
    for (auto& a : interface_addresses()) names.push_back(a);
    names.push_back("localhost");
    char host[256] = {0};
    if (::gethostname(host, sizeof host - 1) == 0 && host[0]) names.push_back(host);
  }
  for (const auto& n : names) {
    add_unique(g.hosts, host_port(n, port));
    add_unique(g.origins, "http://" + host_port(n, port));
  }
  if (port == 80)
    for (const auto& n : names) add_unique(g.hosts, lower(n.find(':') != std::string::npos ? "[" + n + "]" : n));
  for (const auto& o : allow_origins) {
    std::string origin = lower(trim(o));
    while (!origin.empty() && origin.back() == '/') origin.pop_back();
    add_unique(g.origins, origin);
    const size_t scheme = origin.find("://");
    if (scheme != std::string::npos) add_unique(g.hosts, origin.substr(scheme + 3));
  }
  return g;
}

std::optional<Refusal> check_request(const RequestHead& head, const GuardConfig& config) {
  // 1. Host and Origin.
  const auto hosts = values_of(head, "Host");
  if (hosts.size() != 1) return refuse(400, hosts.empty() ? "the Host header is missing" : "more than one Host header");
  const std::string host = lower(trim(*hosts[0]));
  if (std::find(config.hosts.begin(), config.hosts.end(), host) == config.hosts.end())
    return refuse(403, "Host '" + host.substr(0, 100) + "' is not this server's (see --allow-origin)");
  const auto origins = values_of(head, "Origin");
  if (origins.size() > 1) return refuse(403, "more than one Origin header");
  if (origins.size() == 1) {
    const std::string origin = lower(trim(*origins[0]));
    if (std::find(config.origins.begin(), config.origins.end(), origin) == config.origins.end())
      return refuse(403, "Origin '" + origin.substr(0, 100) + "' is not allowed (see --allow-origin)");
  }

  // 2. Method.
  const RouteMatch route = match_route(head.path);
  if (route.known && !route.allows(head.method)) {
    Refusal r = refuse(405, "method " + head.method.substr(0, 20) + " not allowed on " + route.label);
    r.allow = route.allow;
    return r;
  }

  // 3. Token for writes.
  const bool write = head.method == "POST" || head.method == "DELETE";
  if (write && !config.token.empty()) {
    const auto auth = values_of(head, "Authorization");
    const std::string expected = "Bearer " + config.token;
    if (auth.size() != 1 || !constant_time_equal(trim(*auth[0]), expected)) {
      Refusal r = refuse(401, auth.empty() ? "writes need 'Authorization: Bearer <token>'" : "wrong token");
      r.www_authenticate = true;
      return r;
    }
  }

  // 4. Body framing and size.
  const auto lengths = values_of(head, "Content-Length");
  const auto transfer = values_of(head, "Transfer-Encoding");
  if (lengths.size() > 1) return refuse(400, "more than one Content-Length header");
  if (!lengths.empty() && !transfer.empty()) return refuse(400, "both Content-Length and Transfer-Encoding");
  if (transfer.size() > 1 || (transfer.size() == 1 && !iequals(trim(*transfer[0]), "chunked")))
    return refuse(400, "the only transfer coding accepted is 'chunked'");
  unsigned long long declared = 0;
  if (lengths.size() == 1) {
    const std::string v = trim(*lengths[0]);
    if (v.empty() || v.size() > 19 || !std::all_of(v.begin(), v.end(), [](char c) { return c >= '0' && c <= '9'; }))
      return refuse(400, "Content-Length '" + v.substr(0, 30) + "' is not a byte count");
    declared = std::stoull(v);
  }
  const bool has_body = declared > 0 || !transfer.empty();
  if (has_body && head.method != "POST") return refuse(400, head.method.substr(0, 20) + " takes no request body");
  if (declared > config.max_body_bytes)
    return refuse(413, "request body of " + std::to_string(declared) + " bytes is over the limit of " +
                           std::to_string(config.max_body_bytes) + " bytes (--max-body-mib)");
  const auto encodings = values_of(head, "Content-Encoding");
  if (encodings.size() > 1) return refuse(415, "more than one Content-Encoding header");
  if (encodings.size() == 1) {
    const std::string e = trim(*encodings[0]);  // exactly as httplib's decoder matches them
    if (e != "identity" && e != "gzip" && e != "deflate" && e != "br")
      return refuse(415, "Content-Encoding '" + e.substr(0, 30) + "' is not supported (identity, gzip, deflate, br)");
  }
  return std::nullopt;
}

}  // namespace rgbdcast::service
