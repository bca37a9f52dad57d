#pragma once
// Writes a file atomically: a temporary file beside `path`, fsync, rename over `path` (then fsync the directory).
// On failure nothing is left behind and `path` is untouched.
#include <cstdint>
#include <string>
#include <vector>

#include "scene/result.h"

namespace rgbdcast::glb {

Status write_file_atomically(const std::string& path, const std::vector<std::uint8_t>& bytes);
Result<std::vector<std::uint8_t>> read_file_bytes(const std::string& path, size_t max_bytes);

}  // namespace rgbdcast::glb
