#pragma once
// A minimal static-file HTTP/1.0 server on 127.0.0.1 for browser tests (one connection at a time on a background
// thread). GET serves `root` plus extra files mapped by URL path, and relays paths under a forwarded prefix to another
// loopback server (so that a page and the API it reads share one origin); POST stores the body under its path, so that
// a page can hand a result back (wait_for_post). Not for production use.
#include <atomic>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <map>
#include <string>
#include <thread>
#include <vector>

namespace rgbdcast::test {

class StaticHttpServer {
 public:
  explicit StaticHttpServer(std::string root);
  ~StaticHttpServer();
  bool start();  // binds an ephemeral port
  int port() const { return port_; }
  void map(const std::string& url_path, const std::string& file) { extra_[url_path] = file; }
  // GETs of paths starting with `prefix` are relayed, target unchanged, to 127.0.0.1:port as HTTP/1.0 with
  // Connection: close, and its answer (status, headers, body) is passed back as it came; 502 when it cannot connect.
  void forward(const std::string& prefix, int port) { forward_[prefix] = port; }
  // The body of the first POST to any of `paths` within timeout_ms, with the path it came to.
  std::optional<std::pair<std::string, std::string>> wait_for_post(const std::vector<std::string>& paths,
                                                                   int timeout_ms);

 private:
  void serve();
  std::string root_;
  std::map<std::string, std::string> extra_;
  std::map<std::string, int> forward_;
  int fd_ = -1, port_ = 0;
  std::atomic<bool> stop_{false};
  std::thread thread_;
  std::mutex mu_;
  std::condition_variable cv_;
  std::map<std::string, std::string> posted_;
};

}  // namespace rgbdcast::test
