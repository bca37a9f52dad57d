#include "tests/common/test_data.h"

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <mutex>
#include <random>
#include <thread>
#include <vector>

namespace fs = std::filesystem;

namespace rgbdcast::test {

std::string data_path(const std::string& relative) { return (fs::path(RGBDCAST_DATA_DIR) / relative).string(); }
std::string source_path(const std::string& relative) { return (fs::path(RGBDCAST_SOURCE_DIR) / relative).string(); }
std::string binary_path(const std::string& relative) { return (fs::path(RGBDCAST_BINARY_DIR) / relative).string(); }

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

namespace {

// The directories temp_dir made in this test program, removed once its tests are done (gtest tears global
// environments down after the last test, before the program ends).
class TempDirs : public ::testing::Environment {
 public:
  void add(std::string path) {
    std::lock_guard lock(mu_);
    dirs_.push_back(std::move(path));
  }
  void TearDown() override {
    std::lock_guard lock(mu_);
    const char* keep = std::getenv("RGBDCAST_KEEP_TEST_DIRS");
    if (dirs_.empty() || (keep && *keep && std::string(keep) != "0")) return;
    if (::testing::UnitTest::GetInstance()->Failed()) {
      std::cerr << "kept for a look (a test failed):";
      for (const auto& d : dirs_) std::cerr << " " << d;
      std::cerr << "\n";
      return;
    }
    for (const auto& d : dirs_) remove_tree_quietly(d);
  }

 private:
  std::mutex mu_;
  std::vector<std::string> dirs_;
};

// Registered when the program starts, as gtest_main's programs register environments; gtest owns it.
TempDirs* const temp_dirs = static_cast<TempDirs*>(::testing::AddGlobalTestEnvironment(new TempDirs));

}  // namespace

std::string temp_dir(const std::string& tag) {
  std::random_device rd;
  fs::path p = fs::temp_directory_path() / ("rgbdcast-" + tag + "-" + std::to_string(rd()));
  fs::create_directories(p);
  temp_dirs->add(p.string());
  return p.string();
}

}  // namespace rgbdcast::test
