#pragma once
// The in-memory view of a mission store that every implementation keeps (service/mission_store.h): each mission's
// keyframes by seq, its available keyframes in arrival order, its generation and tileset version, and the waiting of
// the event streams. Stores persist first and then tell the index; the index never touches storage. Every change is
// idempotent (applying the same state twice changes nothing), so a store that learns a change twice (its own write,
// then the same change read back from a shared database) keeps one event. Thread-safe.
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "service/mission_store.h"

namespace rgbdcast::service {

class MissionIndex {
 public:
  std::optional<MissionKeyframe> find(const std::string& name, std::int64_t seq) const;
  bool contains(const std::string& name) const;
  // `k` is the current revision of its seq: held unless the index holds a higher rev of the seq already. A new
  // mission gets a new generation. Returns whether anything changed.
  bool upsert(const MissionKeyframe& k);
  // (seq, rev) became viewable at `available` (first_available kept when already set): appended to the arrival order
  // once, and the event streams woken. false (nothing changed) when that revision is not the one held or was
  // available already.
  bool set_available(const std::string& name, std::int64_t seq, std::int64_t rev, double available);
  // A whole mission as loaded at start: arrival order from the stored "available" times; a keyframe without one is
  // available from `now_unix_s` on (views include it as soon as the server serves again).
  void load(const std::string& name, std::map<std::int64_t, MissionKeyframe> by_seq, double now_unix_s);
  bool erase(const std::string& name);  // wakes the event streams; false when unknown

  std::vector<MissionSummary> list() const;
  std::optional<std::vector<MissionKeyframe>> keyframes(const std::string& name) const;
  std::optional<std::vector<MissionKeyframe>> arrivals(const std::string& name) const;
  std::optional<EventCursor> cursor_after(const std::string& name, std::optional<MissionEventId> last_event_id) const;
  EventBatch wait_events(const std::string& name, EventCursor& cursor, std::chrono::milliseconds timeout);
  void set_tileset_version(const std::string& name, std::uint64_t version);
  void wake_all();
  size_t count() const;

 private:
  struct Mission {
    std::uint64_t generation = 0;
    std::map<std::int64_t, MissionKeyframe> by_seq;
    std::vector<MissionKeyframe> arrival;  // available keyframes (each revision as it became available)
    std::set<std::pair<std::int64_t, std::int64_t>> arrived;  // the (seq, rev) of `arrival`
    std::uint64_t tileset_version = 0;
  };
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::map<std::string, Mission> missions_;
  std::uint64_t next_generation_ = 1;
  bool stopped_ = false;  // wake_all() was called
};

}  // namespace rgbdcast::service
