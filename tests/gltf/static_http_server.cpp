#include "tests/gltf/static_http_server.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <cctype>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace rgbdcast::test {

StaticHttpServer::StaticHttpServer(std::string root) : root_(std::move(root)) {}

StaticHttpServer::~StaticHttpServer() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  if (fd_ >= 0) ::close(fd_);
}

bool StaticHttpServer::start() {
  fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd_ < 0) return false;
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = 0;
  if (::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || ::listen(fd_, 16) != 0) return false;
  socklen_t len = sizeof a;
  ::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len);
  port_ = ntohs(a.sin_port);
  thread_ = std::thread([this] { serve(); });
  return true;
}

static std::string mime_of(const std::string& path) {
  auto ends = [&](const char* s) {
    return path.size() >= std::strlen(s) && path.compare(path.size() - std::strlen(s), std::string::npos, s) == 0;
  };
  if (ends(".html")) return "text/html";
  if (ends(".js") || ends(".mjs")) return "text/javascript";
  if (ends(".glb")) return "model/gltf-binary";
  if (ends(".wasm")) return "application/wasm";
  if (ends(".json")) return "application/json";
  return "application/octet-stream";
}

static void send_all(int c, const std::string& out) {
  size_t sent = 0;
  while (sent < out.size()) {
    const ssize_t n = ::send(c, out.data() + sent, out.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) break;
    sent += static_cast<size_t>(n);
  }
}

// GET `target` from 127.0.0.1:port as HTTP/1.0 and pass the raw answer on to the client socket c, until the upstream
// closes (Connection: close) or is silent for 30 s; 502 when it cannot connect.
static void relay_get(int c, int port, const std::string& target) {
  const int u = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  if (u < 0 || ::connect(u, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    if (u >= 0) ::close(u);
    send_all(c, "HTTP/1.0 502 Bad Gateway\r\nContent-Length: 0\r\nConnection: close\r\n\r\n");
    return;
  }
  send_all(u,
           "GET " + target + " HTTP/1.0\r\nHost: 127.0.0.1:" + std::to_string(port) + "\r\nConnection: close\r\n\r\n");
  char buf[65536];
  for (;;) {
    pollfd q{u, POLLIN, 0};
    if (::poll(&q, 1, 30000) <= 0) break;
    const ssize_t n = ::recv(u, buf, sizeof buf, 0);
    if (n <= 0) break;
    send_all(c, std::string(buf, static_cast<size_t>(n)));
  }
  ::close(u);
}

std::optional<std::pair<std::string, std::string>> StaticHttpServer::wait_for_post(
    const std::vector<std::string>& paths, int timeout_ms) {
  std::unique_lock<std::mutex> lock(mu_);
  std::optional<std::pair<std::string, std::string>> out;
  cv_.wait_for(lock, std::chrono::milliseconds(timeout_ms), [&] {
    for (const auto& p : paths)
      if (posted_.count(p)) {
        out = std::make_pair(p, posted_[p]);
        return true;
      }
    return false;
  });
  return out;
}

void StaticHttpServer::serve() {
  while (!stop_) {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, 100) <= 0) continue;
    const int c = ::accept(fd_, nullptr, nullptr);
    if (c < 0) continue;
    std::string req;
    char buf[4096];
    while (req.find("\r\n\r\n") == std::string::npos && req.size() < 65536) {
      pollfd q{c, POLLIN, 0};
      if (::poll(&q, 1, 2000) <= 0) break;
      const ssize_t n = ::recv(c, buf, sizeof buf, 0);
      if (n <= 0) break;
      req.append(buf, static_cast<size_t>(n));
    }
    std::istringstream line(req);
    std::string method, target;
    line >> method >> target;
    std::string path = target.substr(0, target.find('?'));
    if (method == "POST") {
      size_t length = 0;
      std::string lower = req;
      for (auto& ch : lower) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
      const size_t cl = lower.find("content-length:");
      if (cl != std::string::npos) length = std::strtoul(req.c_str() + cl + 15, nullptr, 10);
      const size_t head_end = req.find("\r\n\r\n");
      std::string body = head_end == std::string::npos ? std::string() : req.substr(head_end + 4);
      while (body.size() < length && body.size() < (size_t(64) << 20)) {
        pollfd q{c, POLLIN, 0};
        if (::poll(&q, 1, 5000) <= 0) break;
        const ssize_t n = ::recv(c, buf, sizeof buf, 0);
        if (n <= 0) break;
        body.append(buf, static_cast<size_t>(n));
      }
      const std::string ok = "HTTP/1.0 200 OK\r\nContent-Length: 0\r\nConnection: close\r\n\r\n";
      ::send(c, ok.data(), ok.size(), MSG_NOSIGNAL);
      ::close(c);
      {
        std::lock_guard<std::mutex> lock(mu_);
        posted_[path] = std::move(body);
      }
      cv_.notify_all();
      continue;
    }
    const auto forwarded =
        std::find_if(forward_.begin(), forward_.end(), [&](const auto& f) { return path.rfind(f.first, 0) == 0; });
    if (method == "GET" && forwarded != forward_.end()) {
      relay_get(c, forwarded->second, target);
      ::close(c);
      continue;
    }
    std::string file;
    if (extra_.count(path))
      file = extra_[path];
    else if (path.find("..") == std::string::npos)
      file = root_ + path;
    std::ifstream f(file, std::ios::binary);
    std::string body, head;
    if (method == "GET" && f) {
      body.assign(std::istreambuf_iterator<char>(f), {});
      head = "HTTP/1.0 200 OK\r\nContent-Type: " + mime_of(file) +
             "\r\nContent-Length: " + std::to_string(body.size()) + "\r\nConnection: close\r\n\r\n";
    } else {
      body = "not found";
      head = "HTTP/1.0 404 Not Found\r\nContent-Length: 9\r\nConnection: close\r\n\r\n";
    }
    send_all(c, head + body);
    ::close(c);
  }
}

}  // namespace rgbdcast::test
