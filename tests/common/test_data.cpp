#include "tests/common/test_data.h"

#include <filesystem>
#include <chrono>
#include <random>
#include <thread>

namespace fs = std::filesystem;

namespace rgbdcast::test {

std::string data_path(const std::string& relative) { return (fs::path(RGBDCAST_DATA_DIR) / relative).string(); }
std::string source_path(const std::string& relative) {
  return (fs::path(RGBDCAST_SOURCE_DIR) / relative).string();
}
std::string binary_path(const std::string& relative) {
  return (fs::path(RGBDCAST_BINARY_DIR) / relative).string();
}

bool have_data(const std::string& relative, std::string* message) {
  const std::string p = data_path(relative);
  if (fs::exists(p)) return true;
  *message = "test data missing: " + p + " (the real captures live in ../shared/data beside the repository)";
  return false;
}

void remove_tree_quietly(const std::string& path) {
  for (int attempt = 0; attempt < 20; ++attempt) {
    std::error_code ec;
    fs::remove_all(path, ec);
    if (!ec) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

std::string temp_dir(const std::string& tag) {
  std::random_device rd;
  fs::path p = fs::temp_directory_path() / ("rgbdcast-" + tag + "-" + std::to_string(rd()));
  fs::create_directories(p);
  return p.string();
}

}  // namespace rgbdcast::test
