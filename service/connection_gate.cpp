#include "service/connection_gate.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <mutex>
#include <thread>
#include <unordered_map>
#include <vector>

namespace rgbdcast::service {
namespace {

using Clock = std::chrono::steady_clock;

thread_local bool t_close_after = false;
thread_local bool t_read_failed = false;  // this worker's request: a read of it timed out or failed

Clock::duration seconds(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

int ms_until(Clock::time_point deadline) {
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
  return static_cast<int>(std::clamp<long long>(left, 0, 1 << 30));
}

bool wait_fd(int fd, short events, int timeout_ms) {
  pollfd p{fd, events, 0};
  for (;;) {
    const int r = ::poll(&p, 1, timeout_ms);
    if (r < 0 && errno == EINTR) continue;
    return r > 0 && (p.revents & (events | POLLHUP | POLLERR)) != 0;
  }
}

// Best effort, never blocks: the connection is closed right after.
void send_and_forget(int fd, int status, const char* reason, const char* detail, const std::string& header) {
  char body[256];
  std::snprintf(body, sizeof body, "{\"error\":\"%s\",\"detail\":\"%s\"}\n", reason, detail);
  char msg[768];
  const std::string extra = header.empty() || header.size() > 200 ? "" : header + "\r\n";
  const int n = std::snprintf(msg, sizeof msg,
                              "HTTP/1.1 %d %s\r\nContent-Type: application/json\r\nContent-Length: %zu\r\n"
                              "%sConnection: close\r\n\r\n%s",
                              status, reason, std::strlen(body), extra.c_str(), body);
  if (n > 0) (void)::send(fd, msg, static_cast<size_t>(n), MSG_NOSIGNAL | MSG_DONTWAIT);
}

void ip_and_port(const sockaddr_storage& a, std::string& ip, int& port) {
  char buf[INET6_ADDRSTRLEN] = {0};
  if (a.ss_family == AF_INET) {
    const auto* v4 = reinterpret_cast<const sockaddr_in*>(&a);
    ::inet_ntop(AF_INET, &v4->sin_addr, buf, sizeof buf);
    port = ntohs(v4->sin_port);
  } else if (a.ss_family == AF_INET6) {
    const auto* v6 = reinterpret_cast<const sockaddr_in6*>(&a);
    ::inet_ntop(AF_INET6, &v6->sin6_addr, buf, sizeof buf);
    port = ntohs(v6->sin6_port);
  }
  ip = buf;
}

struct Connection {
  int fd = -1;
  std::string pending;  // bytes received and not yet consumed by a request
  Clock::time_point deadline;
  int served = 0;
  bool lingering = false;  // answered and half-closed: what the client still sends is read and dropped
  ~Connection() {
    if (fd >= 0) {
      ::shutdown(fd, SHUT_RDWR);
      ::close(fd);
    }
  }
  bool has_header_block() const { return pending.find("\r\n\r\n") != std::string::npos; }
};

// The stream a worker gives httplib for one request: the gate's buffered bytes first, then the socket, each wait
// bounded by io_timeout_s and by the minimum body rate.
class GateStream final : public httplib::Stream {
 public:
  GateStream(Connection& c, const GateOptions& o) : c_(c), o_(o), started_(Clock::now()) {}
  ~GateStream() override { c_.pending.erase(0, off_); }

  bool is_readable() const override { return off_ < c_.pending.size() || wait_fd(c_.fd, POLLIN, read_wait_ms()); }
  bool is_writable() const override { return wait_fd(c_.fd, POLLOUT, static_cast<int>(o_.io_timeout_s * 1000)); }

  ssize_t read(char* ptr, size_t size) override {
    if (off_ < c_.pending.size()) {
      const size_t n = std::min(size, c_.pending.size() - off_);
      std::memcpy(ptr, c_.pending.data() + off_, n);
      off_ += n;
      return static_cast<ssize_t>(n);
    }
    if (!wait_fd(c_.fd, POLLIN, read_wait_ms())) {
      failed_ = t_read_failed = true;
      return -1;
    }
    for (;;) {
      const ssize_t n = ::recv(c_.fd, ptr, size, 0);
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
        if (!wait_fd(c_.fd, POLLIN, read_wait_ms())) break;
        continue;
      }
      if (n > 0) socket_bytes_ += static_cast<size_t>(n);
      if (n < 0) failed_ = t_read_failed = true;
      return n;
    }
    failed_ = t_read_failed = true;
    return -1;
  }

  ssize_t write(const char* ptr, size_t size) override {
    for (;;) {
      const ssize_t n = ::send(c_.fd, ptr, size, MSG_NOSIGNAL);
      if (n >= 0) return n;
      if (errno == EINTR) continue;
      if ((errno == EAGAIN || errno == EWOULDBLOCK) && is_writable()) continue;
      failed_ = true;
      return -1;
    }
  }

  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    sockaddr_storage a{};
    socklen_t len = sizeof a;
    if (::getpeername(c_.fd, reinterpret_cast<sockaddr*>(&a), &len) == 0) ip_and_port(a, ip, port);
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    sockaddr_storage a{};
    socklen_t len = sizeof a;
    if (::getsockname(c_.fd, reinterpret_cast<sockaddr*>(&a), &len) == 0) ip_and_port(a, ip, port);
  }
  socket_t socket() const override { return c_.fd; }
  bool failed() const { return failed_; }

 private:
  // How long a read may wait: io_timeout_s, and no later than the minimum body rate allows for the bytes so far.
  int read_wait_ms() const {
    const auto rate_deadline =
        started_ + seconds(o_.body_grace_s + static_cast<double>(socket_bytes_) / o_.body_min_bytes_per_s);
    return std::min(ms_until(rate_deadline), static_cast<int>(o_.io_timeout_s * 1000));
  }

  Connection& c_;
  const GateOptions& o_;
  Clock::time_point started_;
  size_t off_ = 0;
  size_t socket_bytes_ = 0;
  bool failed_ = false;
};

class InlineTaskQueue final : public httplib::TaskQueue {
 public:
  void enqueue(std::function<void()> fn) override { fn(); }
  void shutdown() override {}
};

}  // namespace

struct GatedServer::Impl {
  GatedServer* server = nullptr;
  GateOptions options;
  int epoll_fd = -1;
  int listen_fd = -1;
  std::atomic<bool> stopping{false};
  mutable std::mutex mutex;
  std::condition_variable ready_cv;
  std::unordered_map<int, std::unique_ptr<Connection>> waiting;  // in the gate, by fd
  std::deque<std::unique_ptr<Connection>> ready;                 // a whole header block received
  std::atomic<size_t> open{0}, refused{0}, timed_out{0};
  std::thread gate;
  std::vector<std::thread> workers;

  // Puts a connection in the gate (under the lock); the deadline is the caller's.
  void wait_in_gate(std::unique_ptr<Connection> c) {
    const int fd = c->fd;
    std::lock_guard lock(mutex);
    waiting[fd] = std::move(c);
    epoll_event ev{};
    ev.events = EPOLLIN | EPOLLRDHUP;
    ev.data.fd = fd;
    if (::epoll_ctl(epoll_fd, EPOLL_CTL_ADD, fd, &ev) != 0) drop(fd);
  }
  void drop(int fd) {  // under the lock
    auto it = waiting.find(fd);
    if (it == waiting.end()) return;
    ::epoll_ctl(epoll_fd, EPOLL_CTL_DEL, fd, nullptr);
    waiting.erase(it);
    --open;
  }
  void make_ready(int fd) {  // under the lock
    auto it = waiting.find(fd);
    ::epoll_ctl(epoll_fd, EPOLL_CTL_DEL, fd, nullptr);
    ready.push_back(std::move(it->second));
    waiting.erase(it);
    ready_cv.notify_one();
  }

  // Reads what the socket has; decides between waiting, serving and refusing.
  void on_readable(int fd) {
    std::lock_guard lock(mutex);
    auto it = waiting.find(fd);
    if (it == waiting.end()) return;
    Connection& c = *it->second;
    char buf[8192];
    if (c.lingering) {
      for (;;) {
        const ssize_t n = ::recv(fd, buf, sizeof buf, MSG_DONTWAIT);
        if (n > 0) continue;
        if (n < 0 && errno == EINTR) continue;
        if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;
        return drop(fd);
      }
    }
    for (;;) {
      const ssize_t n = ::recv(fd, buf, sizeof buf, MSG_DONTWAIT);
      if (n > 0) {
        c.pending.append(buf, static_cast<size_t>(n));
        const size_t end = c.pending.find("\r\n\r\n");
        if (end != std::string::npos && end + 4 <= options.max_header_bytes) return make_ready(fd);
        if (end != std::string::npos || c.pending.size() > options.max_header_bytes) {
          send_and_forget(fd, 431, "request_header_fields_too_large", "request line and headers over the limit",
                          options.response_header);
          return drop(fd);
        }
        continue;
      }
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;
      return drop(fd);  // closed by the peer, or an error
    }
  }

  void expire() {
    const auto now = Clock::now();
    std::lock_guard lock(mutex);
    std::vector<int> late;
    for (const auto& [fd, c] : waiting)
      if (c->deadline <= now) late.push_back(fd);
    for (int fd : late) {
      if (waiting[fd]->lingering) {
        drop(fd);
        continue;
      }
      if (!waiting[fd]->pending.empty())
        send_and_forget(fd, 408, "request_timeout", "request headers not received in time", options.response_header);
      ++timed_out;
      drop(fd);
    }
  }

  void run_gate() {
    std::vector<epoll_event> events(256);
    auto next_sweep = Clock::now();
    while (!stopping) {
      const int n = ::epoll_wait(epoll_fd, events.data(), static_cast<int>(events.size()), 50);
      for (int i = 0; i < n; ++i) on_readable(events[i].data.fd);
      if (Clock::now() >= next_sweep) {
        expire();
        next_sweep = Clock::now() + std::chrono::milliseconds(100);
      }
    }
  }

  void run_worker() {
    for (;;) {
      std::unique_ptr<Connection> c;
      {
        std::unique_lock lock(mutex);
        ready_cv.wait(lock, [&] { return stopping || !ready.empty(); });
        if (stopping) return;
        c = std::move(ready.front());
        ready.pop_front();
      }
      const After after = serve(*c);
      if (after == After::kClose) {
        c.reset();
        --open;
        continue;
      }
      if (after == After::kLinger) {
        // The response is out; the client may still be sending the body it was refused. Closing now, with unread
        // bytes, would reset the connection and could destroy the response before the client reads it. So: FIN,
        // then drop what arrives for a short while, in the gate (no worker).
        ::shutdown(c->fd, SHUT_WR);
        c->lingering = true;
        c->pending.clear();
        c->deadline = Clock::now() + seconds(kLingerS);
        wait_in_gate(std::move(c));
        continue;
      }
      c->deadline = Clock::now() + seconds(options.idle_timeout_s);
      if (c->has_header_block()) {  // a pipelined request is already here
        std::lock_guard lock(mutex);
        ready.push_back(std::move(c));
        ready_cv.notify_one();
      } else {
        wait_in_gate(std::move(c));
      }
    }
  }

  enum class After { kKeep, kClose, kLinger };
  static constexpr double kLingerS = 2.0;
  // One request, and what becomes of the connection.
  After serve(Connection& c) {
    const bool last = ++c.served >= options.max_requests_per_connection;
    bool closed = false, ok = false, failed = false;
    t_close_after = false;
    t_read_failed = false;
    {
      GateStream stream(c, options);
      ok = server->serve_request(stream, last, closed);
      failed = stream.failed();
    }
    if (failed || stopping) return After::kClose;
    if (t_close_after) return After::kLinger;
    return ok && !closed && !last ? After::kKeep : After::kClose;
  }
};

GatedServer::GatedServer(const GateOptions& options) : impl_(std::make_unique<Impl>()) {
  impl_->server = this;
  impl_->options = options;
  impl_->options.workers = std::max(1, options.workers);
  impl_->epoll_fd = ::epoll_create1(EPOLL_CLOEXEC);
  new_task_queue = [] { return new InlineTaskQueue(); };
  // Only for the Keep-Alive header httplib writes: the gate itself enforces both.
  set_keep_alive_max_count(static_cast<size_t>(std::max(1, options.max_requests_per_connection)));
  set_keep_alive_timeout(static_cast<time_t>(std::max(1.0, options.idle_timeout_s)));
  // Only SO_REUSEADDR: httplib's default also sets SO_REUSEPORT, which lets a second server share the port.
  set_socket_options([impl = impl_.get()](socket_t sock) {
    int yes = 1;
    ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    impl->listen_fd = sock;  // the last socket httplib tried is the one it bound
  });
  impl_->gate = std::thread([this] { impl_->run_gate(); });
  for (int i = 0; i < impl_->options.workers; ++i) impl_->workers.emplace_back([this] { impl_->run_worker(); });
}

GatedServer::~GatedServer() { shut_down(); }

void GatedServer::shut_down() {
  if (!impl_ || impl_->stopping.exchange(true)) return;
  impl_->ready_cv.notify_all();
  if (impl_->gate.joinable()) impl_->gate.join();
  for (auto& t : impl_->workers)
    if (t.joinable()) t.join();
  std::lock_guard lock(impl_->mutex);
  impl_->waiting.clear();
  impl_->ready.clear();
  if (impl_->epoll_fd >= 0) ::close(impl_->epoll_fd);
  impl_->epoll_fd = -1;
}

GateStats GatedServer::stats() const {
  GateStats s;
  s.open = impl_->open;
  s.refused = impl_->refused;
  s.timed_out = impl_->timed_out;
  std::lock_guard lock(impl_->mutex);
  s.waiting = impl_->waiting.size();
  return s;
}

bool GatedServer::widen_backlog(int backlog) {
  return impl_->listen_fd >= 0 && ::listen(impl_->listen_fd, backlog) == 0;
}

void GatedServer::close_after_response() { t_close_after = true; }

bool GatedServer::request_read_failed() { return t_read_failed; }

bool GatedServer::serve_request(httplib::Stream& stream, bool last, bool& closed) {
  return process_request(stream, last, closed, nullptr);
}

bool GatedServer::process_and_close_socket(socket_t sock) {
  // fds past FD_SETSIZE would make httplib answer 500 (it checks them for select()); refuse well before that.
  if (impl_->stopping || impl_->open >= static_cast<size_t>(impl_->options.max_connections) || sock >= 1000) {
    send_and_forget(sock, 503, "unavailable", "too many connections; retry later", impl_->options.response_header);
    ::shutdown(sock, SHUT_RDWR);
    ::close(sock);
    ++impl_->refused;
    return true;
  }
  ::fcntl(sock, F_SETFL, ::fcntl(sock, F_GETFL) | O_NONBLOCK);
  // No Nagle: httplib writes an answer's headers and its body in two writes, and Nagle holds the body back until the
  // client acknowledges the headers, which a client that waits for the body delays (Linux: 40 ms). That was 40 ms on
  // every keyframe POST and every view (BENCHMARKS.md, "Keyframe POST round trip").
  int yes = 1;
  ::setsockopt(sock, IPPROTO_TCP, TCP_NODELAY, &yes, sizeof yes);
  auto c = std::make_unique<Connection>();
  c->fd = sock;
  c->deadline = Clock::now() + seconds(impl_->options.header_timeout_s);
  ++impl_->open;
  impl_->wait_in_gate(std::move(c));
  return true;
}

}  // namespace rgbdcast::service
