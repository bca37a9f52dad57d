#include "tests/common/test_data.h"

#include <filesystem>
#include <random>

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

std::string temp_dir(const std::string& tag) {
  std::random_device rd;
  fs::path p = fs::temp_directory_path() / ("rgbdcast-" + tag + "-" + std::to_string(rd()));
  fs::create_directories(p);
  return p.string();
}

}  // namespace rgbdcast::test
