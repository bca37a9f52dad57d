#include "service/scene_store.h"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>

#include "base/atomic_file.h"
#include "base/stopwatch.h"

namespace fs = std::filesystem;

namespace rgbdcast::service {
namespace {

constexpr size_t kIdLength = 32;

}  // namespace

namespace {

std::string random_hex(size_t digits) {
  static thread_local std::random_device rd;
  static const char* kHex = "0123456789abcdef";
  std::string s;
  s.reserve(digits);
  while (s.size() < digits) {
    std::uint32_t r = rd();
    for (int i = 0; i < 8 && s.size() < digits; ++i, r >>= 4) s.push_back(kHex[r & 0xf]);
  }
  return s;
}

}  // namespace

Result<std::string> read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return make_error(ErrorCode::kIo, "cannot read " + path);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

namespace {

// The listing's fields of a metadata object, where they have their types; the compact text of the whole object.
void keep_metadata(StoredScene& s, const nlohmann::json& meta) {
  auto count = [&meta](const char* key) -> std::optional<std::uint64_t> {
    const auto it = meta.find(key);
    if (it == meta.end() || !it->is_number_integer()) return std::nullopt;
    if (it->is_number_unsigned()) return it->get<std::uint64_t>();
    const std::int64_t n = it->get<std::int64_t>();
    return n >= 0 ? std::optional<std::uint64_t>(n) : std::nullopt;
  };
  s.points = count("points");
  s.triangles = count("triangles");
  s.vertices = count("vertices");
  const auto source = meta.find("source");
  s.source = source != meta.end() && source->is_string() ? std::optional(source->get<std::string>()) : std::nullopt;
  s.metadata_json = meta.dump();
  s.metadata_json.shrink_to_fit();
}

// The metadata of one stored scene: a JSON object whose bookkeeping fields have their types. Anything else is
// kInvalidInput with the reason (nlohmann's type errors are caught here, never thrown further).
}  // namespace

Result<StoredScene> parse_scene_metadata(const std::string& id, const std::string& text) {
  const nlohmann::json meta = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (meta.is_discarded() || !meta.is_object())
    return make_error(ErrorCode::kInvalidInput, "metadata is not a JSON object");
  try {
    if (meta.contains("id") && meta["id"] != id)
      return make_error(ErrorCode::kInvalidInput, "metadata names another id");
    StoredScene s;
    s.id = id;
    s.bytes = meta.value("bytes", std::uint64_t{0});
    s.etag = meta.value("etag", std::string());
    s.created_unix_s = meta.value("created_unix_s", 0.0);
    keep_metadata(s, meta);
    return s;
  } catch (const nlohmann::json::exception& e) {
    return make_error(ErrorCode::kInvalidInput, std::string("metadata field of the wrong type (") + e.what() + ")");
  }
}

Status quarantine(const std::string& data_dir, const std::string& from_dir, const std::string& stem,
                  const std::string& prefix) {
  const fs::path q = fs::path(data_dir) / "quarantine";
  std::error_code ec;
  fs::create_directories(q, ec);
  if (ec) return make_error(ErrorCode::kIo, "cannot create the quarantine folder: " + ec.message());
  for (const char* ext : {".json", ".glb"}) {
    const fs::path from = fs::path(from_dir) / (stem + ext);
    if (!fs::exists(from, ec)) continue;
    fs::rename(from, q / (prefix + stem + ext), ec);
    if (ec) return make_error(ErrorCode::kIo, "cannot move " + stem + ext + " to quarantine: " + ec.message());
  }
  return fsync_dir(from_dir);
}

nlohmann::json StoredScene::metadata() const {
  nlohmann::json meta = nlohmann::json::parse(metadata_json, nullptr, /*allow_exceptions=*/false);
  return meta.is_object() ? meta : nlohmann::json::object();
}

bool is_valid_scene_id(std::string_view id) {
  if (id.size() != kIdLength) return false;
  return std::all_of(id.begin(), id.end(), [](char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'); });
}

std::string new_scene_id() { return random_hex(kIdLength); }

std::string etag_of(const std::uint8_t* data, size_t size) {
  std::uint64_t h = 1469598103934665603ull;
  for (size_t i = 0; i < size; ++i) {
    h ^= data[i];
    h *= 1099511628211ull;
  }
  char buf[64];
  std::snprintf(buf, sizeof(buf), "\"%016llx-%zu\"", static_cast<unsigned long long>(h), size);
  return buf;
}

Result<std::unique_ptr<SceneStore>> SceneStore::open(const std::string& data_dir) {
  auto store = DirectorySceneStore::open(data_dir);
  if (!store) return store.error();
  return std::unique_ptr<SceneStore>(std::move(*store));
}

Result<std::unique_ptr<DirectorySceneStore>> DirectorySceneStore::open(const std::string& data_dir) {
  if (data_dir.empty()) return make_error(ErrorCode::kInvalidArgument, "data dir is empty");
  const std::string dir = (fs::path(data_dir) / "scenes").string();
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return make_error(ErrorCode::kIo, "cannot create " + dir + ": " + ec.message());
  std::unique_ptr<DirectorySceneStore> store(new DirectorySceneStore(dir));

  // First pass: temporary files of interrupted writes go; committed metadata is loaded.
  std::vector<fs::path> glbs;
  std::vector<std::pair<std::string, std::string>> bad;  // id, why
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(kTempFilePrefix, 0) == 0) {
      fs::remove(entry.path(), ec);
      store->cleaned_.push_back(name);
      continue;
    }
    const std::string stem = entry.path().stem().string(), ext = entry.path().extension().string();
    if (!is_valid_scene_id(stem)) continue;  // not ours: left alone
    if (ext == ".glb") {
      glbs.push_back(entry.path());
    } else if (ext == ".json") {
      auto text = read_text(entry.path().string());
      if (!text) return text.error();
      auto scene = parse_scene_metadata(stem, *text);
      if (!scene) {
        bad.emplace_back(stem, scene.error().message);
        continue;
      }
      store->scenes_.emplace(stem, std::move(*scene));
    }
  }
  for (const auto& [id, why] : bad) {
    auto st = quarantine(data_dir, dir, id, "");
    if (!st) return st.error();
    store->quarantined_.push_back(id + ": " + why + " (moved to quarantine/)");
  }
  if (ec) return make_error(ErrorCode::kIo, "cannot list " + dir + ": " + ec.message());
  // Second pass: a GLB without metadata was never committed (or was being deleted); metadata without its GLB is
  // not a scene either.
  for (const auto& glb : glbs) {
    if (!store->scenes_.count(glb.stem().string()) && fs::exists(glb, ec)) {
      fs::remove(glb, ec);
      store->cleaned_.push_back(glb.filename().string());
    }
  }
  for (auto it = store->scenes_.begin(); it != store->scenes_.end();) {
    if (!fs::exists(store->glb_path(it->first))) {
      fs::remove(fs::path(dir) / (it->first + ".json"), ec);
      store->cleaned_.push_back(it->first + ".json");
      it = store->scenes_.erase(it);
    } else {
      ++it;
    }
  }
  if (!store->cleaned_.empty()) {
    auto st = fsync_dir(dir);
    if (!st) return st.error();
  }
  return store;
}

StoredScene new_stored_scene(const std::vector<std::uint8_t>& glb, nlohmann::json& metadata) {
  if (!metadata.is_object()) metadata = nlohmann::json::object();
  StoredScene s;
  s.id = new_scene_id();
  s.bytes = glb.size();
  s.etag = etag_of(glb.data(), glb.size());
  s.created_unix_s = unix_seconds_now();
  metadata["id"] = s.id;
  metadata["bytes"] = s.bytes;
  metadata["etag"] = s.etag;
  metadata["created_unix_s"] = s.created_unix_s;
  keep_metadata(s, metadata);
  return s;
}

Result<StoredScene> DirectorySceneStore::put(const std::vector<std::uint8_t>& glb, nlohmann::json metadata) {
  StoredScene s = new_stored_scene(glb, metadata);

  auto st = write_file_atomically(dir_ + "/" + s.id + ".glb", glb.data(), glb.size());
  if (!st) return st.error();
  const std::string text = metadata.dump(2);
  st = write_file_atomically(dir_ + "/" + s.id + ".json", text.data(), text.size());
  if (!st) {
    std::error_code ec;
    fs::remove(glb_path(s.id), ec);
    return st.error();
  }
  std::lock_guard lock(mutex_);
  scenes_[s.id] = s;
  return s;
}

std::optional<StoredScene> DirectorySceneStore::get(const std::string& id) const {
  if (!is_valid_scene_id(id)) return std::nullopt;
  std::lock_guard lock(mutex_);
  auto it = scenes_.find(id);
  if (it == scenes_.end()) return std::nullopt;
  return it->second;
}

std::vector<StoredScene> DirectorySceneStore::list() const {
  std::vector<StoredScene> out;
  {
    std::lock_guard lock(mutex_);
    for (const auto& [id, s] : scenes_) out.push_back(s);
  }
  std::stable_sort(out.begin(), out.end(),
                   [](const StoredScene& a, const StoredScene& b) { return a.created_unix_s < b.created_unix_s; });
  return out;
}

void DirectorySceneStore::for_each(const std::function<void(const StoredScene&)>& f) const {
  std::lock_guard lock(mutex_);
  std::vector<const StoredScene*> order;
  order.reserve(scenes_.size());
  for (const auto& [id, s] : scenes_) order.push_back(&s);
  std::stable_sort(order.begin(), order.end(),
                   [](const StoredScene* a, const StoredScene* b) { return a->created_unix_s < b->created_unix_s; });
  for (const StoredScene* s : order) f(*s);
}

Status DirectorySceneStore::remove(const std::string& id) {
  if (!is_valid_scene_id(id)) return make_error(ErrorCode::kNotFound, "no scene " + id);
  {
    std::lock_guard lock(mutex_);
    if (!scenes_.erase(id)) return make_error(ErrorCode::kNotFound, "no scene " + id);
  }
  // Metadata first: once it is gone the scene is gone, whatever happens to the GLB.
  std::error_code ec;
  fs::remove(fs::path(dir_) / (id + ".json"), ec);
  if (ec) return make_error(ErrorCode::kIo, "cannot delete metadata of " + id + ": " + ec.message());
  fs::remove(glb_path(id), ec);
  return fsync_dir(dir_);
}

Result<std::vector<std::uint8_t>> DirectorySceneStore::read_glb(const std::string& id) const {
  if (!get(id)) return make_error(ErrorCode::kNotFound, "no scene " + id);
  std::ifstream in(glb_path(id), std::ios::binary);
  if (!in) return make_error(ErrorCode::kNotFound, "no scene " + id);
  std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), {});
  return bytes;
}

std::string DirectorySceneStore::glb_path(const std::string& id) const { return dir_ + "/" + id + ".glb"; }

size_t DirectorySceneStore::count() const {
  std::lock_guard lock(mutex_);
  return scenes_.size();
}

std::uint64_t DirectorySceneStore::total_bytes() const {
  std::lock_guard lock(mutex_);
  std::uint64_t n = 0;
  for (const auto& [id, s] : scenes_) n += s.bytes;
  return n;
}

}  // namespace rgbdcast::service
