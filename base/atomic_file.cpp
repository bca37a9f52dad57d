#include "base/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>

namespace rgbdcast {
namespace {

std::string errno_text() { return std::strerror(errno); }

// 8 random hex digits: concurrent writers of one name each get a temporary file of their own (O_EXCL refuses a
// name in use, so a collision is an error, never a shared file).
std::string random_suffix() {
  static thread_local std::random_device rd;
  char buf[9];
  std::snprintf(buf, sizeof buf, "%08x", static_cast<unsigned>(rd()));
  return buf;
}

}  // namespace

Status fsync_dir(const std::string& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return make_error(ErrorCode::kIo, "cannot open folder " + dir + ": " + errno_text());
  const int rc = ::fsync(fd);
  ::close(fd);
  if (rc != 0) return make_error(ErrorCode::kIo, "cannot fsync folder " + dir + ": " + errno_text());
  return ok_status();
}

Status write_file_atomically(const std::string& path, const void* data, size_t size) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  const std::string dir = target.has_parent_path() ? target.parent_path().string() : std::string(".");
  const std::string tmp = dir + "/" + kTempFilePrefix + target.filename().string() + "-" + random_suffix();
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) return make_error(ErrorCode::kIo, "cannot create " + tmp + ": " + errno_text());
  const auto* p = static_cast<const char*>(data);
  size_t left = size;
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const std::string why = n < 0 ? errno_text() : "nothing written";
      ::close(fd);
      ::unlink(tmp.c_str());
      return make_error(ErrorCode::kIo, "cannot write " + tmp + ": " + why);
    }
    p += n;
    left -= static_cast<size_t>(n);
  }
  if (::fsync(fd) != 0) {
    const std::string why = errno_text();
    ::close(fd);
    ::unlink(tmp.c_str());
    return make_error(ErrorCode::kIo, "cannot flush " + tmp + ": " + why);
  }
  if (::close(fd) != 0) {
    const std::string why = errno_text();
    ::unlink(tmp.c_str());
    return make_error(ErrorCode::kIo, "cannot flush " + tmp + ": " + why);
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string why = errno_text();
    ::unlink(tmp.c_str());
    return make_error(ErrorCode::kIo, "cannot rename " + tmp + " to " + path + ": " + why);
  }
  return fsync_dir(dir);
}

Result<std::vector<std::uint8_t>> read_file_bytes(const std::string& path, size_t max_bytes) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return make_error(ErrorCode::kNotFound, "cannot open " + path);
  f.seekg(0, std::ios::end);
  const std::streamoff n = f.tellg();
  if (n < 0) return make_error(ErrorCode::kIo, "cannot read " + path);
  if (static_cast<size_t>(n) > max_bytes)
    return make_error(ErrorCode::kInvalidInput, path + " is larger than " + std::to_string(max_bytes) + " bytes");
  f.seekg(0);
  std::vector<std::uint8_t> bytes(static_cast<size_t>(n));
  if (n > 0 && !f.read(reinterpret_cast<char*>(bytes.data()), n))
    return make_error(ErrorCode::kIo, "cannot read " + path);
  return bytes;
}

}  // namespace rgbdcast
