#include "tiles/tile_storage.h"

#include <charconv>
#include <filesystem>
#include <mutex>

#include <nlohmann/json.hpp>

#include "base/atomic_file.h"

namespace rgbdcast::tiles {
namespace fs = std::filesystem;
namespace {

constexpr const char* kRecordFile = "hierarchy.json";
constexpr size_t kMaxRecordBytes = size_t(256) << 20;
constexpr size_t kMaxTileBytes = size_t(512) << 20;

class DirectoryTileStorage final : public TileStorage {
 public:
  explicit DirectoryTileStorage(std::string dir) : dir_(std::move(dir)) {}

  Result<std::optional<TileRecordBytes>> read_record() override {
    const std::string path = dir_ + "/" + kRecordFile;
    std::error_code ec;
    if (!fs::exists(path, ec)) return std::optional<TileRecordBytes>();
    auto bytes = read_file_bytes(path, kMaxRecordBytes);
    if (!bytes) return bytes.error();
    TileRecordBytes r{version_in(*bytes), std::move(*bytes)};
    std::lock_guard lock(mutex_);
    known_version_ = r.version;
    return std::optional<TileRecordBytes>(std::move(r));
  }

  Result<std::uint64_t> committed_version() override {
    {
      std::lock_guard lock(mutex_);
      if (known_version_) return *known_version_;
    }
    auto r = read_record();
    if (!r) return r.error();
    return *r ? (*r)->version : 0;
  }

  Status write_tile(const std::string& file, const std::vector<std::uint8_t>& bytes) override {
    {
      std::lock_guard lock(mutex_);
      if (kept_.count(file)) return ok_status();  // committed: immutable
    }
    return write_file_atomically(dir_ + "/" + file, bytes);
  }

  Result<std::vector<std::uint8_t>> read_tile(const std::string& file) const override {
    return read_file_bytes(dir_ + "/" + file, kMaxTileBytes);
  }

  Result<std::string> local_file(const std::string& file) const override {
    std::string path = dir_ + "/" + file;
    std::error_code ec;
    if (!fs::exists(path, ec)) return make_error(ErrorCode::kNotFound, "no tile file " + path);
    return path;
  }

  Result<bool> commit(const TileCommit& c) override {
    auto committed = committed_version();
    if (!committed) return committed.error();
    if (*committed >= c.version) return false;
    std::error_code ec;
    for (const auto& [f, size] : c.named)
      if (fs::file_size(dir_ + "/" + f, ec) != size || ec) return false;
    if (auto st = write_file_atomically(dir_ + "/" + kRecordFile, c.record); !st) return st.error();
    {
      std::lock_guard lock(mutex_);
      known_version_ = c.version;
      kept_ = c.retained;
      for (const auto& [f, size] : c.named) kept_.insert(f);
    }
    for (const auto& f : c.garbage)
      if (!c.named.count(f) && !c.retained.count(f)) fs::remove(dir_ + "/" + f, ec);
    return true;
  }

  Status delete_tiles(const std::set<std::string>& files) override {
    std::lock_guard lock(mutex_);
    std::error_code ec;
    for (const auto& f : files)
      if (!kept_.count(f)) fs::remove(dir_ + "/" + f, ec);
    return ok_status();
  }

  // The folder is this process's alone: whatever the record does not name is a cut update's or an older version's.
  Status collect(const std::set<std::string>& named, std::uint64_t) override {
    {
      std::lock_guard lock(mutex_);
      kept_ = named;
    }
    std::error_code ec;
    for (const auto& entry : fs::directory_iterator(dir_, ec)) {
      const std::string name = entry.path().filename().string();
      if (name != kRecordFile && !named.count(name)) fs::remove_all(entry.path(), ec);
    }
    if (ec) return make_error(ErrorCode::kIo, "tiles: cannot list " + dir_ + ": " + ec.message());
    return ok_status();
  }

  Status remove() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
    std::lock_guard lock(mutex_);
    known_version_ = 0;
    if (ec) return make_error(ErrorCode::kIo, "tiles: cannot remove " + dir_ + ": " + ec.message());
    return ok_status();
  }

  std::string where() const override { return dir_; }

 private:
  // The record's "version"; 0 for a record that does not say (the hierarchy then starts again anyway).
  static std::uint64_t version_in(const std::vector<std::uint8_t>& bytes) {
    const auto j = nlohmann::json::parse(bytes.begin(), bytes.end(), nullptr, false);
    if (j.is_discarded() || !j.is_object() || !j.contains("version") || !j["version"].is_number_unsigned()) return 0;
    return j["version"].get<std::uint64_t>();
  }

  std::string dir_;
  std::mutex mutex_;
  std::optional<std::uint64_t> known_version_;  // the committed record's, once read or written
  std::set<std::string> kept_;                  // what the committed record names or retains, as this storage learnt it
};

}  // namespace

Result<std::unique_ptr<TileStorage>> directory_tile_storage(const std::string& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return make_error(ErrorCode::kIo, "tiles: cannot create " + dir + ": " + ec.message());
  return std::unique_ptr<TileStorage>(new DirectoryTileStorage(dir));
}

std::optional<std::uint64_t> tile_file_version(const std::string& file) {
  constexpr std::string_view kSuffix = ".glb";
  if (file.size() <= kSuffix.size() || file.compare(file.size() - kSuffix.size(), kSuffix.size(), kSuffix) != 0)
    return std::nullopt;
  const std::string_view stem(file.data(), file.size() - kSuffix.size());
  const size_t dot = stem.rfind(".v");
  if (dot == std::string_view::npos || dot + 2 >= stem.size()) return std::nullopt;
  std::uint64_t v = 0;
  const char* first = stem.data() + dot + 2;
  const char* last = stem.data() + stem.size();
  auto [end, err] = std::from_chars(first, last, v);
  if (err != std::errc() || end != last) return std::nullopt;
  return v;
}

}  // namespace rgbdcast::tiles
