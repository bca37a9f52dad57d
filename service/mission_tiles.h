#pragma once
// Keeps each live mission's tile hierarchy (tiles/tile_hierarchy.h) up to date, off the keyframe POST's path, with two
// threads:
// - the leaf worker: a POST only names its mission to it, and it commits the leaves of the keyframes the store holds
//   (TileHierarchy::add_leaves: several keyframes posted meanwhile make one commit). It never waits for an inner
//   tile's build, so a keyframe reaches the tileset in the time its own leaf takes.
// - the sweeper: builds the stale inner tiles once they are due (TilingOptions::settle_s, max_stale_s; it sleeps until
//   then), one at a time (TileHierarchy::next_build; build_tile outside the mission's lock; finish_build), each its
//   own commit; a build whose children changed meanwhile is dropped, and picked again once due.
// Each commit tells the event streams the new version (MissionStore::set_tileset_version). Contract:
// - Hierarchies live in a TileStorage per mission (tiles/tile_storage.h), made by the storage factory: by default
//   the folder <data_dir>/tiles/<mission>/; with a shared database, its rows (cached in that folder). They survive
//   restarts: start() names every stored mission to the worker, which opens the committed hierarchy and builds only
//   what it lacks.
// - With a storage shared by replicas, before each update the worker opens the hierarchy again when another replica
//   committed a newer one, and a commit refused because another replica committed first (TileHierarchy::superseded)
//   is not a failure: the mission is opened again and updated from there. A replica thus takes a mission over from
//   the stored tiles, building only what they lack.
// - The queue holds each mission at most once, so it is bounded by the number of missions, and serves them in turn.
// - A keyframe or tile that fails to build leaves the mission's last committed tileset served; the error is counted
//   and kept (last_error), and the next keyframe (or the next sweep) tries again.
// - forget() (the mission was deleted) drops the hierarchy and its storage (TileStorage::remove).
// - stop() ends the leaf worker between two leaves (uncommitted: the next start builds them again) and the sweeper
//   after the tile it is building, so a server shutting down waits for one tile at most.
// Thread-safe.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>

#include "scene/result.h"
#include "service/mission_store.h"
#include "tiles/tile_hierarchy.h"
#include "tiles/tile_storage.h"

namespace rgbdcast::service {

struct MissionTilesStats {
  std::uint64_t updates = 0, failures = 0, leaves_built = 0, inner_built = 0, bytes_written = 0;
  std::uint64_t opened_committed = 0;  // hierarchies opened with a committed version (loaded, not built)
  std::uint64_t superseded = 0;        // commits refused because another replica committed first
  double update_seconds = 0.0;         // summed over updates
  std::string last_error;
};

// A mission's storage given its name and its folder on this machine.
using TileStorageFactory =
    std::function<Result<std::unique_ptr<tiles::TileStorage>>(const std::string& mission, const std::string& dir)>;

class MissionTiles {
 public:
  // `storage` empty: the directory store.
  MissionTiles(std::string data_dir, MissionStore& missions, tiles::TilingOptions options = {},
               TileStorageFactory storage = {});
  ~MissionTiles();  // stops the worker (an update under way finishes first)
  MissionTiles(const MissionTiles&) = delete;
  MissionTiles& operator=(const MissionTiles&) = delete;

  void start();  // starts the worker and names every stored mission to it
  void stop();
  void enqueue(const std::string& mission);
  void forget(const std::string& mission);
  // The mission's committed tileset; nullptr before its hierarchy was opened (no keyframe yet, or still queued).
  std::shared_ptr<const tiles::TilesetSnapshot> snapshot(const std::string& mission) const;
  // A path on this machine holding a tile file of the mission (fetched from the storage when needed); kNotFound
  // when the mission's hierarchy is not open or the file is not stored (a tile of an older version, removed).
  Result<std::string> tile_file(const std::string& mission, const std::string& file) const;
  // Waits until nothing is queued, waiting for its tiles to be due or being built, or `timeout_s` passed; true when
  // idle (tests, benchmarks).
  bool wait_idle(double timeout_s) const;
  MissionTilesStats stats() const;

 private:
  struct Entry {  // a mission's hierarchy: opened by the leaf worker, used by both threads under `lock`
    std::mutex lock;
    std::shared_ptr<tiles::TileHierarchy> hierarchy;  // shared: the sweeper builds outside `lock` on its copy
  };
  void run();
  void sweep();
  void update_one(const std::string& mission);
  void sweep_one(const std::string& mission);
  void enqueue_at(const std::string& mission, std::chrono::steady_clock::time_point due);
  double now_s() const;
  void published(const std::string& mission, Entry& entry, const tiles::UpdateStats& stats);
  void failed(const std::string& what);
  std::string tile_dir(const std::string& mission) const;
  Result<std::shared_ptr<tiles::TileStorage>> open_storage(const std::string& mission) const;
  Status open_hierarchy(const std::string& mission, Entry& entry);
  // After a failed call on the hierarchy: when another replica committed first, the mission is opened again.
  bool superseded(const std::string& mission, Entry& entry);
  std::string root_;
  MissionStore& missions_;
  tiles::TilingOptions options_;
  TileStorageFactory storage_;
  mutable std::mutex mutex_;
  mutable std::condition_variable cv_;
  std::set<std::string> queue_;    // the missions waiting, each once
  std::deque<std::string> order_;  // the same, first come first served (a mission that steps again goes last)
  std::map<std::string, std::chrono::steady_clock::time_point> delayed_;  // the sweeper's: stale tiles due then
  std::chrono::steady_clock::time_point epoch_;  // the hierarchies' clock (TileHierarchy's now_s) starts here
  std::string busy_;                             // the mission the leaf worker is updating, or empty
  std::string sweeping_;                         // the mission the sweeper is building a tile of, or empty
  bool stopping_ = false;
  std::atomic<bool> stop_update_{false};  // set by stop(), read by the update under way
  std::map<std::string, std::unique_ptr<Entry>> hierarchies_;
  std::map<std::string, std::shared_ptr<const tiles::TilesetSnapshot>> snapshots_;
  std::map<std::string, std::shared_ptr<tiles::TileStorage>> storages_;  // of the open hierarchies, for readers
  MissionTilesStats stats_;
  std::thread worker_, sweeper_;
};

}  // namespace rgbdcast::service
