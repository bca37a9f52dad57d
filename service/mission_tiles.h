#pragma once
// Keeps each live mission's tile hierarchy (tiles/tile_hierarchy.h) up to date, off the keyframe POST's path: a POST
// only names its mission to a background worker, which steps the mission's hierarchy (TileHierarchy::step): first the
// leaves of the keyframes the store holds (so several keyframes posted meanwhile make one commit), then sweeps over
// the stale inner tiles once they are due (TilingOptions::settle_s, max_stale_s: the worker sleeps until then), one
// commit each, that give way as soon as the mission has new keyframes again. Each commit tells the event streams the
// new version (MissionStore::set_tileset_version). Contract:
// - Hierarchies live in <data_dir>/tiles/<mission>/ and survive restarts: start() names every stored mission to the
//   worker, which builds only what the committed hierarchy lacks.
// - The queue holds each mission at most once, so it is bounded by the number of missions, and serves them in turn;
//   one worker thread.
// - A keyframe that fails to build leaves the mission's last committed tileset served; the error is counted and kept
//   (last_error), and the next keyframe of the mission tries again.
// - forget() (the mission was deleted) drops the hierarchy and its folder.
// - stop() ends an update under way between two tiles (uncommitted: the next start builds it again), so a server
//   shutting down does not wait for it.
// Thread-safe.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>

#include "scene/result.h"
#include "service/mission_store.h"
#include "tiles/tile_hierarchy.h"

namespace rgbdcast::service {

struct MissionTilesStats {
  std::uint64_t updates = 0, failures = 0, leaves_built = 0, inner_built = 0, bytes_written = 0;
  double update_seconds = 0.0;  // summed over updates
  std::string last_error;
};

class MissionTiles {
 public:
  MissionTiles(std::string data_dir, MissionStore& missions, tiles::TilingOptions options = {});
  ~MissionTiles();  // stops the worker (an update under way finishes first)
  MissionTiles(const MissionTiles&) = delete;
  MissionTiles& operator=(const MissionTiles&) = delete;

  void start();  // starts the worker and names every stored mission to it
  void stop();
  void enqueue(const std::string& mission);
  void forget(const std::string& mission);
  // The mission's committed tileset; nullptr before its hierarchy was opened (no keyframe yet, or still queued).
  std::shared_ptr<const tiles::TilesetSnapshot> snapshot(const std::string& mission) const;
  // The folder of the mission's tile files.
  std::string tile_dir(const std::string& mission) const;
  // Waits until nothing is queued, waiting for its tiles to be due or being built, or `timeout_s` passed; true when
  // idle (tests, benchmarks).
  bool wait_idle(double timeout_s) const;
  MissionTilesStats stats() const;

 private:
  void run();
  void update_one(const std::string& mission);
  void enqueue_at(const std::string& mission, std::chrono::steady_clock::time_point due);

  std::string root_;
  MissionStore& missions_;
  tiles::TilingOptions options_;
  mutable std::mutex mutex_;
  mutable std::condition_variable cv_;
  std::set<std::string> queue_;    // the missions waiting, each once
  std::deque<std::string> order_;  // the same, first come first served (a mission that steps again goes last)
  std::map<std::string, std::chrono::steady_clock::time_point> delayed_;  // stale tiles due then
  std::chrono::steady_clock::time_point epoch_;  // the hierarchies' clock (TileHierarchy::step's now_s) starts here
  std::string busy_;  // the mission being updated, or empty
  bool stopping_ = false;
  std::atomic<bool> stop_update_{false};  // set by stop(), read by the update under way
  std::map<std::string, std::unique_ptr<tiles::TileHierarchy>> hierarchies_;  // used by the worker only
  std::map<std::string, std::shared_ptr<const tiles::TilesetSnapshot>> snapshots_;
  MissionTilesStats stats_;
  std::thread worker_;
};

}  // namespace rgbdcast::service
