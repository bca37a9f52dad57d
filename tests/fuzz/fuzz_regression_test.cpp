// Replays, in the ordinary build, every seed of fuzz/corpus/<target>/ and every input that once crashed a fuzzer
// (tests/fuzz/crashes/<target>/, named after the bug) through the same fuzz targets libFuzzer runs
// (fuzz/fuzz_targets.h). A crash found once stays fixed; run it under build-asan/ for the sanitizers' view.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <map>

#include "fuzz/fuzz_targets.h"

namespace fs = std::filesystem;

namespace {

using Target = std::function<void(const std::uint8_t*, size_t)>;

const std::map<std::string, Target>& targets() {
  static const std::map<std::string, Target> t = {{"glb", rgbdcast::fuzz::glb},
                                                  {"draco", rgbdcast::fuzz::draco},
                                                  {"intrinsics", rgbdcast::fuzz::intrinsics},
                                                  {"frame_decode", rgbdcast::fuzz::frame_decode},
                                                  {"frame_upload", rgbdcast::fuzz::frame_upload},
                                                  {"multipart", rgbdcast::fuzz::multipart},
                                                  {"pcd", rgbdcast::fuzz::pcd},
                                                  {"trajectory", rgbdcast::fuzz::trajectory},
                                                  {"view_query", rgbdcast::fuzz::view_query},
                                                  {"rosbag", rgbdcast::fuzz::rosbag}};
  return t;
}

size_t replay(const fs::path& dir, const Target& target) {
  if (!fs::is_directory(dir)) return 0;
  size_t n = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    std::ifstream in(e.path(), std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    SCOPED_TRACE(e.path().string());
    target(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
    ++n;
  }
  return n;
}

}  // namespace

TEST(FuzzRegression, EverySeedRunsCleanly) {
  const fs::path corpus = fs::path(RGBDCAST_SOURCE_DIR) / "fuzz" / "corpus";
  for (const auto& [name, target] : targets()) {
    const size_t n = replay(corpus / name, target);
    EXPECT_GE(n, 2u) << "seed corpus of " << name;
    std::printf("%-13s %zu seeds\n", name.c_str(), n);
  }
}

TEST(FuzzRegression, EveryCrashFoundStaysFixed) {
  const fs::path crashes = fs::path(RGBDCAST_SOURCE_DIR) / "tests" / "fuzz" / "crashes";
  size_t total = 0;
  for (const auto& [name, target] : targets()) {
    const size_t n = replay(crashes / name, target);
    if (n) std::printf("%-13s %zu former crash inputs\n", name.c_str(), n);
    total += n;
  }
  for (const auto& e : fs::directory_iterator(crashes))
    EXPECT_TRUE(!e.is_directory() || targets().count(e.path().filename().string())) << "unknown target " << e.path();
  std::printf("%zu former crash inputs replayed\n", total);
}
