#include "service/mission_tiles.h"

#include <chrono>
#include <filesystem>
#include <iostream>

#include "service/mission_scene.h"

namespace rgbdcast::service {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

MissionTiles::MissionTiles(std::string data_dir, MissionStore& missions, tiles::TilingOptions options,
                           TileStorageFactory storage)
    : root_((fs::path(data_dir) / "tiles").string()),
      missions_(missions),
      options_(std::move(options)),
      storage_(std::move(storage)),
      epoch_(Clock::now()) {}

MissionTiles::~MissionTiles() { stop(); }

void MissionTiles::start() {
  {
    std::lock_guard lock(mutex_);
    if (worker_.joinable()) return;
    stopping_ = false;
    stop_update_ = false;
  }
  std::error_code ec;
  fs::create_directories(root_, ec);
  // Hierarchies of missions that no longer exist (deleted while the server was down) go.
  std::set<std::string> live;
  for (const auto& m : missions_.list()) live.insert(m.name);
  for (const auto& entry : fs::directory_iterator(root_, ec))
    if (!live.count(entry.path().filename().string())) fs::remove_all(entry.path(), ec);
  worker_ = std::thread([this] { run(); });
  sweeper_ = std::thread([this] { sweep(); });
  for (const auto& name : live) enqueue(name);
}

void MissionTiles::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    stop_update_ = true;
  }
  cv_.notify_all();
  if (worker_.joinable()) worker_.join();
  if (sweeper_.joinable()) sweeper_.join();
}

void MissionTiles::enqueue(const std::string& mission) {
  {
    std::lock_guard lock(mutex_);
    if (queue_.insert(mission).second) order_.push_back(mission);
  }
  cv_.notify_all();
}

void MissionTiles::enqueue_at(const std::string& mission, Clock::time_point due) {
  {
    std::lock_guard lock(mutex_);
    auto [it, added] = delayed_.emplace(mission, due);
    if (!added) it->second = std::min(it->second, due);
  }
  cv_.notify_all();
}

void MissionTiles::forget(const std::string& mission) {
  std::unique_lock lock(mutex_);
  queue_.erase(mission);
  std::erase(order_, mission);
  delayed_.erase(mission);
  cv_.wait(lock, [&] { return busy_ != mission && sweeping_ != mission; });  // what is under way finishes first
  hierarchies_.erase(mission);
  snapshots_.erase(mission);
  auto storage = storages_.count(mission) ? storages_[mission] : nullptr;
  storages_.erase(mission);
  lock.unlock();
  if (!storage) {  // never opened here: its folder (and, when shared, its rows) may still hold tiles
    auto opened = open_storage(mission);
    if (opened) storage = std::move(*opened);
  }
  if (storage)
    if (auto st = storage->remove(); !st) failed("mission " + mission + ": " + st.error().message);
  std::error_code ec;
  fs::remove_all(tile_dir(mission), ec);
}

std::shared_ptr<const tiles::TilesetSnapshot> MissionTiles::snapshot(const std::string& mission) const {
  std::lock_guard lock(mutex_);
  auto it = snapshots_.find(mission);
  return it == snapshots_.end() ? nullptr : it->second;
}

std::string MissionTiles::tile_dir(const std::string& mission) const { return root_ + "/" + mission; }

Result<std::string> MissionTiles::tile_file(const std::string& mission, const std::string& file) const {
  std::shared_ptr<tiles::TileStorage> storage;
  {
    std::lock_guard lock(mutex_);
    auto it = storages_.find(mission);
    if (it == storages_.end()) return make_error(ErrorCode::kNotFound, "no tiles of mission " + mission + " yet");
    storage = it->second;
  }
  return storage->local_file(file);
}

Result<std::shared_ptr<tiles::TileStorage>> MissionTiles::open_storage(const std::string& mission) const {
  auto storage = storage_ ? storage_(mission, tile_dir(mission)) : tiles::directory_tile_storage(tile_dir(mission));
  if (!storage) return storage.error();
  return std::shared_ptr<tiles::TileStorage>(std::move(*storage));
}

// Opens (or opens again) the mission's hierarchy from its storage; entry.lock held.
Status MissionTiles::open_hierarchy(const std::string& mission, Entry& entry) {
  auto storage = open_storage(mission);
  if (!storage) return storage.error();
  auto opened = tiles::TileHierarchy::open(*storage, options_);
  if (!opened) return opened.error();
  entry.hierarchy = std::move(*opened);
  std::lock_guard lock(mutex_);
  storages_[mission] = *storage;
  if (entry.hierarchy->version() > 0) {
    ++stats_.opened_committed;
    std::cerr << "tiles: mission " << mission << ": opened version " << entry.hierarchy->version() << " from "
              << (*storage)->where() << "\n";
  }
  return ok_status();
}

bool MissionTiles::superseded(const std::string& mission, Entry& entry) {
  if (!entry.hierarchy || !entry.hierarchy->superseded()) return false;
  entry.hierarchy.reset();  // the next update opens what the other replica committed
  {
    std::lock_guard lock(mutex_);
    ++stats_.superseded;
  }
  enqueue(mission);
  return true;
}

bool MissionTiles::wait_idle(double timeout_s) const {
  std::unique_lock lock(mutex_);
  return cv_.wait_for(lock, std::chrono::duration<double>(timeout_s), [&] {
    return (queue_.empty() && delayed_.empty() && busy_.empty() && sweeping_.empty()) || stopping_;
  });
}

MissionTilesStats MissionTiles::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

double MissionTiles::now_s() const { return std::chrono::duration<double>(Clock::now() - epoch_).count(); }

void MissionTiles::failed(const std::string& what) {
  std::lock_guard lock(mutex_);
  ++stats_.failures;
  stats_.last_error = what;
  std::cerr << "tiles: " << what << "\n";
}

// After a call on the hierarchy (entry.lock held): the snapshot readers see, the version event when it committed, and
// the sweeper's next due time.
void MissionTiles::published(const std::string& mission, Entry& entry, const tiles::UpdateStats& stats) {
  bool changed = false;
  {
    std::lock_guard lock(mutex_);
    auto& snapshot = snapshots_[mission];
    changed = !snapshot || snapshot->version != entry.hierarchy->version();
    snapshot = entry.hierarchy->snapshot();
  }
  if (changed) missions_.set_tileset_version(mission, entry.hierarchy->version());
  if (stats.stale > 0)
    enqueue_at(mission, epoch_ + std::chrono::duration_cast<Clock::duration>(
                                     std::chrono::duration<double>(std::max(0.0, stats.next_sweep_s))));
}

void MissionTiles::run() {
  std::unique_lock lock(mutex_);
  while (true) {
    cv_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
    if (stopping_) return;
    busy_ = order_.front();
    order_.pop_front();
    queue_.erase(busy_);
    const std::string mission = busy_;
    lock.unlock();
    update_one(mission);
    lock.lock();
    busy_.clear();
    cv_.notify_all();
  }
}

void MissionTiles::sweep() {
  std::unique_lock lock(mutex_);
  while (true) {
    if (stopping_) return;
    // The mission whose stale tiles are due first.
    auto first = delayed_.end();
    for (auto it = delayed_.begin(); it != delayed_.end(); ++it)
      if (first == delayed_.end() || it->second < first->second) first = it;
    if (first == delayed_.end()) {
      cv_.wait(lock);
      continue;
    }
    if (first->second > Clock::now()) {
      cv_.wait_until(lock, first->second);
      continue;  // woken early, late or for something else: look again
    }
    sweeping_ = first->first;
    delayed_.erase(first);
    const std::string mission = sweeping_;
    lock.unlock();
    sweep_one(mission);
    lock.lock();
    sweeping_.clear();
    cv_.notify_all();
  }
}

void MissionTiles::update_one(const std::string& mission) {
  const auto t0 = Clock::now();
  auto keyframes = missions_.keyframes(mission);
  if (!keyframes) return;  // deleted meanwhile
  Entry* entry = nullptr;
  {
    std::lock_guard lock(mutex_);  // forget() erases entries, but never one in use
    auto& slot = hierarchies_[mission];
    if (!slot) slot = std::make_unique<Entry>();
    entry = slot.get();
  }
  std::lock_guard hold(entry->lock);
  if (entry->hierarchy) {  // another replica may have committed since (a storage shared by replicas)
    auto committed = entry->hierarchy->storage().committed_version();
    if (committed && *committed > entry->hierarchy->version()) entry->hierarchy.reset();
  }
  if (!entry->hierarchy)
    if (auto st = open_hierarchy(mission, *entry); !st) return failed("mission " + mission + ": " + st.error().message);
  std::vector<tiles::KeyframeId> wanted;
  std::map<std::int64_t, const MissionKeyframe*> by_seq;
  for (const auto& k : *keyframes) {
    wanted.push_back({k.seq, k.rev});
    by_seq[k.seq] = &k;
  }
  auto updated = entry->hierarchy->add_leaves(
      wanted,
      [&](const tiles::KeyframeId& id) -> Result<Scene> {
        auto it = by_seq.find(id.seq);
        if (it == by_seq.end()) return make_error(ErrorCode::kNotFound, "not stored");
        return load_placed_keyframe(missions_, *it->second);
      },
      std::chrono::duration<double>(t0 - epoch_).count(), &stop_update_);
  if (!updated && stop_update_) return;  // stopped: uncommitted, not a failure
  if (!updated && superseded(mission, *entry)) return;
  if (!updated) {
    published(mission, *entry, entry->hierarchy->status(now_s()));
    return failed("mission " + mission + ": " + updated.error().message);
  }
  {
    std::lock_guard lock(mutex_);
    ++stats_.updates;
    stats_.leaves_built += updated->leaves_built;
    stats_.bytes_written += updated->bytes_written;
    stats_.update_seconds += std::chrono::duration<double>(Clock::now() - t0).count();
  }
  published(mission, *entry, *updated);
}

void MissionTiles::sweep_one(const std::string& mission) {
  Entry* entry = nullptr;
  {
    std::lock_guard lock(mutex_);
    auto it = hierarchies_.find(mission);
    if (it == hierarchies_.end()) return;
    entry = it->second.get();
  }
  const auto t0 = Clock::now();
  std::optional<tiles::TileHierarchy::PendingBuild> pending;
  std::shared_ptr<tiles::TileHierarchy> hierarchy;
  {
    std::lock_guard hold(entry->lock);
    if (!entry->hierarchy) return;
    hierarchy = entry->hierarchy;
    pending = hierarchy->next_build(now_s());
    // None due yet (a keyframe came since it was scheduled): come back when one is.
    if (!pending) return published(mission, *entry, hierarchy->status(now_s()));
  }
  auto built = hierarchy->build_tile(*pending);  // no lock: the leaf worker commits meanwhile
  std::lock_guard hold(entry->lock);
  if (entry->hierarchy != hierarchy) {  // opened again meanwhile: this build is of a hierarchy no longer served
    if (built) (void)hierarchy->storage().delete_tiles({built->file()});
    if (entry->hierarchy) published(mission, *entry, entry->hierarchy->status(now_s()));
    return;
  }
  auto finished = entry->hierarchy->finish_build(*pending, std::move(built), now_s());
  if (!finished && superseded(mission, *entry)) return;
  if (!finished) {
    published(mission, *entry, entry->hierarchy->status(now_s()));
    return failed("mission " + mission + ": " + finished.error().message);
  }
  {
    std::lock_guard lock(mutex_);
    stats_.inner_built += finished->inner_built;
    stats_.bytes_written += finished->bytes_written;
    stats_.update_seconds += std::chrono::duration<double>(Clock::now() - t0).count();
  }
  published(mission, *entry, *finished);
}

}  // namespace rgbdcast::service
