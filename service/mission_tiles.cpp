#include "service/mission_tiles.h"

#include <chrono>
#include <filesystem>
#include <iostream>

#include "service/mission_scene.h"

namespace rgbdcast::service {
namespace fs = std::filesystem;

namespace {
double seconds_since(std::chrono::steady_clock::time_point epoch, std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(t - epoch).count();
}
}  // namespace

MissionTiles::MissionTiles(std::string data_dir, MissionStore& missions, tiles::TilingOptions options)
    : root_((fs::path(data_dir) / "tiles").string()),
      missions_(missions),
      options_(std::move(options)),
      epoch_(std::chrono::steady_clock::now()) {}

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
}

void MissionTiles::enqueue(const std::string& mission) {
  {
    std::lock_guard lock(mutex_);
    if (queue_.insert(mission).second) order_.push_back(mission);
  }
  cv_.notify_all();
}

void MissionTiles::enqueue_at(const std::string& mission, std::chrono::steady_clock::time_point due) {
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
  cv_.wait(lock, [&] { return busy_ != mission; });  // an update under way finishes first
  hierarchies_.erase(mission);
  snapshots_.erase(mission);
  std::error_code ec;
  fs::remove_all(tile_dir(mission), ec);
}

std::shared_ptr<const tiles::TilesetSnapshot> MissionTiles::snapshot(const std::string& mission) const {
  std::lock_guard lock(mutex_);
  auto it = snapshots_.find(mission);
  return it == snapshots_.end() ? nullptr : it->second;
}

std::string MissionTiles::tile_dir(const std::string& mission) const { return root_ + "/" + mission; }

bool MissionTiles::wait_idle(double timeout_s) const {
  std::unique_lock lock(mutex_);
  return cv_.wait_for(lock, std::chrono::duration<double>(timeout_s),
                      [&] { return (queue_.empty() && delayed_.empty() && busy_.empty()) || stopping_; });
}

MissionTilesStats MissionTiles::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

void MissionTiles::run() {
  std::unique_lock lock(mutex_);
  while (true) {
    // Missions whose stale tiles are due join the queue.
    const auto now = std::chrono::steady_clock::now();
    auto next = std::chrono::steady_clock::time_point::max();
    for (auto it = delayed_.begin(); it != delayed_.end();) {
      if (it->second > now) {
        next = std::min(next, it->second);
        ++it;
        continue;
      }
      if (queue_.insert(it->first).second) order_.push_back(it->first);
      it = delayed_.erase(it);
    }
    if (stopping_) return;
    if (queue_.empty()) {
      if (next == std::chrono::steady_clock::time_point::max())
        cv_.wait(lock);
      else
        cv_.wait_until(lock, next);
      continue;  // woken early, late or for nothing: look again
    }
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

void MissionTiles::update_one(const std::string& mission) {
  const auto t0 = std::chrono::steady_clock::now();
  auto keyframes = missions_.keyframes(mission);
  if (!keyframes) return;  // deleted meanwhile
  std::unique_ptr<tiles::TileHierarchy>* slot = nullptr;
  {
    std::lock_guard lock(mutex_);  // forget() erases entries, but never the one being updated
    slot = &hierarchies_[mission];
  }
  auto& hierarchy = *slot;
  auto fail = [&](const std::string& what) {
    std::lock_guard lock(mutex_);
    ++stats_.failures;
    stats_.last_error = "mission " + mission + ": " + what;
    std::cerr << "tiles: " << stats_.last_error << "\n";
  };
  if (!hierarchy) {
    auto opened = tiles::TileHierarchy::open(tile_dir(mission), options_);
    if (!opened) return fail(opened.error().message);
    hierarchy = std::move(*opened);
  }
  std::vector<tiles::KeyframeId> wanted;
  std::map<std::int64_t, const MissionKeyframe*> by_seq;
  for (const auto& k : *keyframes) {
    wanted.push_back({k.seq, k.rev});
    by_seq[k.seq] = &k;
  }
  // One step: new keyframes' leaves, else a sweep over stale tiles that yields as soon as this mission has new
  // keyframes waiting (a POST enqueued it again), so a keyframe reaches the tileset after at most one tile's build.
  auto updated = hierarchy->step(
      wanted,
      [&](const tiles::KeyframeId& id) -> Result<Scene> {
        auto it = by_seq.find(id.seq);
        if (it == by_seq.end()) return make_error(ErrorCode::kNotFound, "not stored");
        return load_placed_keyframe(missions_, *it->second);
      },
      seconds_since(epoch_, t0), &stop_update_,
      [&] {
        std::lock_guard lock(mutex_);
        return queue_.count(mission) > 0;
      });
  if (!updated && stop_update_) return;  // stopped: uncommitted, not a failure
  {
    std::lock_guard lock(mutex_);
    snapshots_[mission] = hierarchy->snapshot();
  }
  if (!updated) return fail(updated.error().message);
  {
    std::lock_guard lock(mutex_);
    ++stats_.updates;
    stats_.leaves_built += updated->leaves_built;
    stats_.inner_built += updated->inner_built;
    stats_.bytes_written += updated->bytes_written;
    stats_.update_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  missions_.set_tileset_version(mission, hierarchy->version());
  if (updated->stale > 0)  // the sweep goes on when its next tile is due, after whatever else waits
    enqueue_at(mission, epoch_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                     std::chrono::duration<double>(updated->next_sweep_s)));
}

}  // namespace rgbdcast::service
