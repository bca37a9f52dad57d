#include "base/atomic_file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <string>

namespace rgbdcast {
namespace {

namespace fs = std::filesystem;

class AtomicFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = (fs::temp_directory_path() /
            ("rgbdcast-atomic-" + std::to_string(::getpid()) + "-" + std::to_string(std::random_device{}())))
               .string();
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string read(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }
  size_t entries() const { return static_cast<size_t>(std::distance(fs::directory_iterator(dir_), {})); }
  std::string dir_;
};

TEST_F(AtomicFile, WritesTheWholeFileAndLeavesNoTemporary) {
  const std::string path = dir_ + "/scene.glb";
  const std::vector<std::uint8_t> bytes = {0x67, 0x6c, 0x54, 0x46, 0x00, 0xff};
  ASSERT_TRUE(write_file_atomically(path, bytes).ok());
  const std::string back = read(path);
  EXPECT_EQ(std::vector<std::uint8_t>(back.begin(), back.end()), bytes);
  EXPECT_EQ(entries(), 1u);
}

TEST_F(AtomicFile, ReplacesAnExistingFile) {
  const std::string path = dir_ + "/report.json";
  ASSERT_TRUE(write_file_atomically(path, std::string_view("{\"old\": true, \"longer\": 1}")).ok());
  ASSERT_TRUE(write_file_atomically(path, std::string_view("{}")).ok());
  EXPECT_EQ(read(path), "{}");
  EXPECT_EQ(entries(), 1u);
}

TEST_F(AtomicFile, EmptyFile) {
  const std::string path = dir_ + "/empty";
  ASSERT_TRUE(write_file_atomically(path, std::vector<std::uint8_t>{}).ok());
  EXPECT_TRUE(fs::exists(path));
  EXPECT_EQ(fs::file_size(path), 0u);
}

TEST_F(AtomicFile, LargeFileIsWrittenWhole) {
  std::string text(3u << 20, '\0');
  for (size_t i = 0; i < text.size(); ++i) text[i] = static_cast<char>(i * 7 + i / 4096);
  const std::string path = dir_ + "/big.bin";
  ASSERT_TRUE(write_file_atomically(path, text.data(), text.size()).ok());
  EXPECT_EQ(read(path), text);
}

TEST_F(AtomicFile, MissingFolderIsAnIoErrorAndLeavesNothing) {
  const Status st = write_file_atomically(dir_ + "/missing/x.bin", std::string_view("x"));
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::kIo);
  EXPECT_NE(st.error().message.find(dir_ + "/missing"), std::string::npos) << st.error().message;
  EXPECT_EQ(entries(), 0u);
}

TEST_F(AtomicFile, TargetThatIsAFolderIsUntouchedAndNoTemporaryIsLeft) {
  fs::create_directories(dir_ + "/taken/inner");
  const Status st = write_file_atomically(dir_ + "/taken", std::string_view("x"));
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::kIo);
  EXPECT_TRUE(fs::is_directory(dir_ + "/taken/inner"));
  for (const auto& e : fs::directory_iterator(dir_))
    EXPECT_NE(e.path().filename().string().rfind(kTempFilePrefix, 0), 0u) << "left behind: " << e.path();
}

TEST_F(AtomicFile, FsyncOfAMissingFolderIsAnIoError) {
  EXPECT_TRUE(fsync_dir(dir_).ok());
  const Status st = fsync_dir(dir_ + "/none");
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::kIo);
}

TEST_F(AtomicFile, ReadFileBytesHonoursItsLimit) {
  const std::string path = dir_ + "/ten";
  ASSERT_TRUE(write_file_atomically(path, std::string_view("0123456789")).ok());
  auto whole = read_file_bytes(path, 10);
  ASSERT_TRUE(whole.ok());
  EXPECT_EQ(whole->size(), 10u);
  EXPECT_EQ((*whole)[9], '9');
  auto over = read_file_bytes(path, 9);
  ASSERT_FALSE(over.ok());
  EXPECT_EQ(over.error().code, ErrorCode::kInvalidInput);
  auto missing = read_file_bytes(dir_ + "/none", 10);
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::kNotFound);
}

}  // namespace
}  // namespace rgbdcast
