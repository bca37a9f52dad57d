#pragma once
// Starts the real `rgbdcast serve` binary on a free loopback port (--port 0; the port is read from its "listening
// on" line) and stops it with SIGTERM, or kills it with SIGKILL. For the HTTP and browser tests.
#include <sys/types.h>

#include <string>
#include <vector>

#include "tests/common/run_command.h"  // rgbdcast_binary()

namespace rgbdcast::test {

class ServerProcess {
 public:
  ServerProcess() = default;
  ~ServerProcess();
  ServerProcess(const ServerProcess&) = delete;
  ServerProcess& operator=(const ServerProcess&) = delete;

  // The address given to --bind (default 127.0.0.1; any loopback address works for the tests).
  void set_bind(const std::string& address) { bind_ = address; }
  // Starts `rgbdcast serve --data-dir dir --bind <bind> --port 0 <extra>`; waits up to timeout_s for the port.
  // On failure returns false with the server's output in *error.
  bool start(const std::string& data_dir, const std::vector<std::string>& extra, std::string* error,
             double timeout_s = 60.0);
  // SIGTERM and wait (SIGKILL after timeout_s). Returns the exit status as waitpid gives it, or -1.
  int stop(double timeout_s = 20.0);
  // SIGKILL and wait.
  void kill9();
  bool running() const { return pid_ > 0; }
  int port() const { return port_; }
  pid_t pid() const { return pid_; }
  const std::string& output() const { return output_; }

 private:
  pid_t pid_ = -1;
  int out_fd_ = -1;
  int port_ = 0;
  std::string bind_ = "127.0.0.1";
  std::string output_;
};

// Frame 0 of TUM fr1/xyz as the multipart route takes it (colour PNG, 16-bit depth PNG, intrinsics JSON).
struct FrameFiles {
  std::string color, depth, intrinsics_json;
};
FrameFiles fr1_frame0();
std::string read_file(const std::string& path);

}  // namespace rgbdcast::test
