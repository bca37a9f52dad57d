#include "tests/service/server_process.h"

#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <regex>
#include <sstream>
#include <thread>

#include "tests/common/test_data.h"

namespace rgbdcast::test {

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

FrameFiles fr1_frame0() {
  const std::string root = data_path("tum/rgbd_dataset_freiburg1_xyz/");
  FrameFiles f;
  f.color = read_file(root + "rgb/1305031102.175304.png");
  f.depth = read_file(root + "depth/1305031102.160407.png");
  // TUM's published fr1 calibration (../shared/data/README.md), OpenCV distortion order k1 k2 p1 p2 k3.
  f.intrinsics_json = R"({"fx": 517.3, "fy": 516.5, "cx": 318.6, "cy": 255.3, "width": 640, "height": 480,
                          "distortion": [0.2624, -0.9531, -0.0054, 0.0026, 1.1633], "depth_scale": 5000})";
  return f;
}

ServerProcess::~ServerProcess() {
  if (pid_ <= 0) return;
  // Under the sanitizers (scripts/sanitize.sh, scripts/sanitized_subset.sh set RGBDCAST_SANITIZED=1) a server the
  // test left running is stopped with SIGTERM, not killed, so that LeakSanitizer's check at its exit runs, and
  // anything but a clean exit fails the test: ASan and UBSan abort the server at once (abort_on_error,
  // halt_on_error), LeakSanitizer reports only when it exits.
  if (const char* s = std::getenv("RGBDCAST_SANITIZED"); s && std::string(s) == "1") {
    const int status = stop(60.0);
    if (!(WIFEXITED(status) && WEXITSTATUS(status) == 0))
      ADD_FAILURE() << "rgbdcast serve did not exit cleanly on SIGTERM at the end of the test (waitpid status "
                    << status << "): a sanitizer report? Run the test alone with the server's output kept";
    return;
  }
  kill9();
}

bool ServerProcess::start(const std::string& data_dir, const std::vector<std::string>& extra, std::string* error,
                          double timeout_s) {
  int fds[2];
  if (pipe(fds) != 0) {
    *error = "pipe failed";
    return false;
  }
  std::vector<std::string> args = {rgbdcast_binary(), "serve", "--data-dir", data_dir, "--bind", bind_, "--port", "0"};
  // RGBDCAST_TEST_BACKEND=osmesa|vulkan runs the suite on one backend (default: the server's auto choice).
  if (const char* backend = std::getenv("RGBDCAST_TEST_BACKEND"); backend && *backend) {
    args.push_back("--backend");
    args.push_back(backend);
  }
  args.insert(args.end(), extra.begin(), extra.end());
  const pid_t pid = fork();
  if (pid < 0) {
    *error = "fork failed";
    return false;
  }
  if (pid == 0) {
    dup2(fds[1], 1);
    dup2(fds[1], 2);
    close(fds[0]);
    close(fds[1]);
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    execv(argv[0], argv.data());
    _exit(127);
  }
  close(fds[1]);
  pid_ = pid;
  out_fd_ = fds[0];
  output_.clear();
  const std::regex listening(R"(listening on http://[^ ]+:(\d+)/)");
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < deadline) {
    pollfd p{out_fd_, POLLIN, 0};
    if (poll(&p, 1, 100) > 0) {
      char buf[4096];
      const ssize_t n = read(out_fd_, buf, sizeof buf);
      if (n <= 0) break;  // the server exited
      output_.append(buf, static_cast<size_t>(n));
      std::smatch m;
      if (std::regex_search(output_, m, listening)) {
        port_ = std::stoi(m[1].str());
        // Keep the pipe drained so the server never blocks on a full pipe.
        const int fd = out_fd_;
        std::thread([fd] {
          char b[4096];
          while (read(fd, b, sizeof b) > 0) {}
          close(fd);
        }).detach();
        out_fd_ = -1;
        return true;
      }
    }
  }
  *error = "server did not report a port; output:\n" + output_;
  kill9();
  return false;
}

int ServerProcess::stop(double timeout_s) {
  if (pid_ <= 0) return -1;
  ::kill(pid_, SIGTERM);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  int status = 0;
  while (std::chrono::steady_clock::now() < deadline) {
    const pid_t r = waitpid(pid_, &status, WNOHANG);
    if (r == pid_) {
      pid_ = -1;
      return status;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  kill9();
  return -1;
}

void ServerProcess::kill9() {
  if (pid_ <= 0) return;
  ::kill(pid_, SIGKILL);
  int status = 0;
  waitpid(pid_, &status, 0);
  pid_ = -1;
  if (out_fd_ >= 0) {
    close(out_fd_);
    out_fd_ = -1;
  }
}

}  // namespace rgbdcast::test
