#pragma once
// The project's one atomic file writer. write_file_atomically writes `dir/.tmp-<name>-<random>` (kTempFilePrefix),
// fsyncs it, renames it over `dir/name` and fsyncs the folder, so that after a crash the file is either the old one
// or the whole new one. On failure the temporary file is removed and the target is untouched; the error is kIo with
// the path and the system's reason. Stores that open a folder remove what a crash left behind by the prefix.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "base/result.h"

namespace rgbdcast {

inline constexpr const char* kTempFilePrefix = ".tmp-";  // what the writer's temporary names start with

Status write_file_atomically(const std::string& path, const void* data, size_t size);
inline Status write_file_atomically(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  return write_file_atomically(path, bytes.data(), bytes.size());
}
inline Status write_file_atomically(const std::string& path, std::string_view text) {
  return write_file_atomically(path, text.data(), text.size());
}

// fsync of a folder (after a rename or removal in it); kIo when it cannot be opened or synced.
Status fsync_dir(const std::string& dir);

// A whole file of at most max_bytes: kNotFound when it cannot be opened, kInvalidInput when it is larger, kIo when a
// read fails.
Result<std::vector<std::uint8_t>> read_file_bytes(const std::string& path, size_t max_bytes);

}  // namespace rgbdcast
