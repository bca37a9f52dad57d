#pragma once
// Where tests find the real captures of ../shared/data. A test that needs data it cannot find is skipped on a
// developer's machine and fails under CI (CI=true), saying which path is missing.
#include <gtest/gtest.h>

#include <string>

namespace rgbdcast::test {

// Absolute path of a file or folder under ../shared/data.
std::string data_path(const std::string& relative);
// True when the path exists; otherwise records the skip or failure (see REQUIRE_DATA).
bool have_data(const std::string& relative, std::string* message);
// A fresh empty temporary directory for one test. Every one made in a test program is removed after its last test
// when none failed; when one failed they are kept for a look and listed (RGBDCAST_KEEP_TEST_DIRS=1 keeps them always).
std::string temp_dir(const std::string& tag);
std::string source_path(const std::string& relative);
// Removes a test's folder, best effort: a browser's helper processes may still be writing into it for a moment after
// the browser was ended, so failures are retried briefly and then ignored (it is only temporary output).
void remove_tree_quietly(const std::string& path);
std::string binary_path(const std::string& relative);

}  // namespace rgbdcast::test

// A test whose prerequisite (data, a tool) is missing: skipped with the message on a developer's machine, failed
// under CI=true.
#define RGBDCAST_MISSING_PREREQUISITE(message)                         \
  do {                                                                 \
    if (std::getenv("CI") && std::string(std::getenv("CI")) == "true") \
      FAIL() << (message);                                             \
    else                                                               \
      GTEST_SKIP() << (message);                                       \
  } while (0)

#define REQUIRE_DATA(relative)                                                                                \
  do {                                                                                                        \
    std::string rgbdcast_msg_;                                                                                \
    if (!::rgbdcast::test::have_data(relative, &rgbdcast_msg_)) RGBDCAST_MISSING_PREREQUISITE(rgbdcast_msg_); \
  } while (0)
