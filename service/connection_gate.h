#pragma once
// cpp-httplib's Server with the connection handling replaced: in 0.11.4 every accepted connection holds a
// pool thread from accept to close, so idle or slow clients (200 idle connections, 16 slowloris clients at 1 byte/s)
// take every thread and /healthz waits for minutes. Here:
// - one gate thread (epoll) holds every connection that is between requests or still sending its header block; it
//   costs no worker. A request goes to a worker only when its whole header block (up to max_header_bytes) has
//   arrived; a header block not complete within header_timeout_s gets 408, a larger one 431, and the connection
//   closes. Keep-alive connections go back to the gate between requests and close after idle_timeout_s.
// - workers run httplib's request processing (routing, handlers) on a stream that enforces a minimum body rate
//   (after body_grace_s, at least body_min_bytes_per_s on average), so a slow body frees its worker within seconds.
// - at most max_connections are open; more are answered 503 and closed at once.
// A handler that answers without reading the body it was sent calls close_after_response(): the connection is then
// closed after the response instead of reading the unread body as the next request.
// httplib.h must be compiled with the flags the library was built with (../shared/STACK.md).
#include <httplib.h>

#include <cstddef>
#include <memory>
#include <string>

namespace rgbdcast::service {

struct GateOptions {
  int workers = 32;                 // threads that process requests
  double header_timeout_s = 5.0;    // accept (or the end of the previous request) to the end of the header block
  double idle_timeout_s = 5.0;      // keep-alive connection without a new request
  size_t max_header_bytes = 16384;  // request line and headers
  int max_connections = 512;
  int max_requests_per_connection = 100;
  double io_timeout_s = 10.0;  // one read or write while a worker serves the request
  double body_grace_s = 3.0;
  double body_min_bytes_per_s = 4096.0;
  std::string response_header;  // "Name: value" added to the gate's own answers (408, 431, 503), or empty
};

struct GateStats {
  size_t open = 0;       // connections open now
  size_t waiting = 0;    // of which in the gate (idle or sending headers)
  size_t refused = 0;    // over max_connections, since start
  size_t timed_out = 0;  // header or idle timeout, since start
};

class GatedServer : public httplib::Server {
 public:
  explicit GatedServer(const GateOptions& options);
  ~GatedServer() override;
  GatedServer(const GatedServer&) = delete;
  GatedServer& operator=(const GatedServer&) = delete;

  // Stops the gate and the workers and closes every connection (call after stop(), or from the destructor).
  void shut_down();
  // After bind_to_port / bind_to_any_port: httplib 0.11.4 listens with a backlog of 5, so a burst of connections
  // (slow clients reconnecting when the gate cuts them) overflows the accept queue, the kernel drops SYNs and a fresh
  // client waits for its 1 s SYN retransmit. Listening again on the bound socket raises the backlog (Linux).
  bool widen_backlog(int backlog = 1024);
  GateStats stats() const;
  // From a handler: close the connection once this response is written.
  static void close_after_response();
  // On a worker, while it answers a request: a read of that request timed out or failed (its body stopped arriving,
  // or came slower than the minimum rate). httplib then answers 400; the service makes that a 408 (not a verdict on
  // bytes it never got: a client retries a 408).
  static bool request_read_failed();

 private:
  // Called by httplib's accept loop for each accepted socket (the task queue runs it inline): hands the socket to
  // the gate and returns at once.
  bool process_and_close_socket(socket_t sock) override;
  bool serve_request(httplib::Stream& stream, bool last, bool& closed);  // httplib's process_request, once
  struct Impl;
  std::unique_ptr<Impl> impl_;
  friend struct Impl;
};

}  // namespace rgbdcast::service
