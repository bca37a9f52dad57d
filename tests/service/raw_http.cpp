#include "tests/service/raw_http.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>
#include <zlib.h>

#include <cctype>
#include <chrono>
#include <thread>

#include "base/stopwatch.h"

namespace rgbdcast::test {

int connect_loopback(int port, const char* address) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<uint16_t>(port));
  ::inet_pton(AF_INET, address, &a.sin_addr);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

bool send_all(int fd, const std::string& s) {
  size_t off = 0;
  while (off < s.size()) {
    const ssize_t n = ::send(fd, s.data() + off, s.size() - off, MSG_NOSIGNAL);
    if (n <= 0) return false;
    off += static_cast<size_t>(n);
  }
  return true;
}

RawResponse read_response(int fd, double timeout_s) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  const auto deadline = t0 + std::chrono::duration<double>(timeout_s);
  RawResponse r;
  std::string data;
  size_t header_end = std::string::npos, need = std::string::npos;
  char buf[65536];
  while (Clock::now() < deadline) {
    const int left =
        static_cast<int>(std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count());
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, std::max(1, left)) <= 0) break;
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    data.append(buf, static_cast<size_t>(n));
    if (header_end == std::string::npos) {
      header_end = data.find("\r\n\r\n");
      if (header_end != std::string::npos) {
        const std::string head = data.substr(0, header_end);
        if (head.rfind("HTTP/1.", 0) == 0 && head.size() > 12) {
          r.ok = true;
          r.status = std::atoi(head.c_str() + 9);
        }
        size_t pos = head.find("\r\n");
        while (pos != std::string::npos && pos < head.size()) {
          const size_t next = head.find("\r\n", pos + 2);
          const std::string line = head.substr(pos + 2, (next == std::string::npos ? head.size() : next) - pos - 2);
          const size_t colon = line.find(':');
          if (colon != std::string::npos) {
            std::string name = line.substr(0, colon);
            for (auto& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
            std::string value = line.substr(colon + 1);
            while (!value.empty() && value.front() == ' ') value.erase(0, 1);
            r.headers[name] = value;
          }
          pos = next;
        }
        if (r.headers.count("content-length")) need = header_end + 4 + std::stoul(r.headers["content-length"]);
      }
    }
    if (need != std::string::npos && data.size() >= need) break;
  }
  if (header_end != std::string::npos) r.body = data.substr(header_end + 4);
  if (need != std::string::npos && r.body.size() > need - header_end - 4) r.body.resize(need - header_end - 4);
  r.ms = ms_since(t0);
  return r;
}

RawResponse raw_request(int port, const std::string& request, double timeout_s) {
  const auto t0 = std::chrono::steady_clock::now();
  const int fd = connect_loopback(port);
  if (fd < 0) return {};
  // Send from another thread: the server may answer (and stop reading) before the whole request is out.
  std::thread sender([fd, &request] { send_all(fd, request); });
  RawResponse r = read_response(fd, timeout_s);
  ::shutdown(fd, SHUT_RDWR);
  sender.join();
  ::close(fd);
  r.ms = ms_since(t0);
  return r;
}

std::string read_event_stream_until(int port, const std::string& path, const std::string& needle, double timeout_s) {
  const int fd = connect_loopback(port);
  if (fd < 0) return "";
  send_all(fd, "GET " + path + " HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port) +
                   "\r\nAccept: text/event-stream\r\n\r\n");
  std::string text;
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (text.find(needle) == std::string::npos) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - std::chrono::steady_clock::now());
    if (left.count() <= 0) break;
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) break;
    char buf[8192];
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    text.append(buf, static_cast<size_t>(n));
  }
  ::close(fd);
  return text;
}

std::string gunzip(const std::string& in) {
  z_stream z{};
  if (inflateInit2(&z, 15 + 16) != Z_OK) return "";
  std::string out;
  char buf[1 << 16];
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in.data()));
  z.avail_in = static_cast<uInt>(in.size());
  int rc = Z_OK;
  while (rc == Z_OK) {
    z.next_out = reinterpret_cast<Bytef*>(buf);
    z.avail_out = sizeof buf;
    rc = inflate(&z, Z_NO_FLUSH);
    out.append(buf, sizeof buf - z.avail_out);
  }
  inflateEnd(&z);
  return rc == Z_STREAM_END ? out : "";
}

}  // namespace rgbdcast::test
