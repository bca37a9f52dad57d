#pragma once
// Live missions on disk (issue 10): <data_dir>/missions/<name>/<seq>.glb (the keyframe GLB as the robot sent it) and
// <seq>.json (its pose, sizes and times). Contract:
// - put() writes the GLB, then the JSON, each with write_file_atomic (service/scene_store.h: temporary name, fsync,
//   rename, fsync of the folder); the JSON is the commit marker, so a crash leaves a whole keyframe or none.
// - Idempotency key (name, seq): a put() of a stored key with the same GLB bytes and the same pose is kSame (nothing
//   written, the stored keyframe returned); with other bytes or another pose kConflict (nothing written).
// - A keyframe is put() first and mark_available() once views include it; only available keyframes are events.
//   Events are in arrival order (the order keyframes became available), which is seq order only when the sender sends
//   in seq order; after a restart the order is rebuilt from the stored "available" times.
// - open() deletes what an interrupted put() or remove() left (temporary files, a GLB without its JSON, a mission
//   folder being deleted), and moves a keyframe JSON that does not parse or has a field of the wrong type, with its
//   GLB, to <data_dir>/quarantine/mission-<name>-<seq>.json|.glb (one line each in quarantined()); the rest is served.
// - remove() renames the mission folder to a hidden name first (one atomic step), then deletes it.
// - Names are [A-Za-z0-9_-]{1,64} and seqs 0..2^31-1, checked before they reach a path.
// Thread-safe: every method may be called from any thread; writes are serialized inside.
#include <array>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "scene/result.h"

namespace rgbdcast::service {

bool is_valid_mission_name(std::string_view name);
inline constexpr std::int64_t kMaxKeyframeSeq = 2147483647;

struct MissionKeyframe {
  std::string mission;
  std::int64_t seq = 0;
  std::array<double, 7> pose{};  // tx ty tz qx qy qz qw: camera-to-world, OpenCV camera convention (as posted)
  std::uint64_t bytes = 0;       // of the GLB
  std::uint64_t triangles = 0;
  double captured = 0.0;         // the sender's capture time, Unix s
  double received = 0.0;         // when the POST arrived, Unix s
  double available = 0.0;        // when views include it, Unix s; 0 until mark_available()
  std::string etag;              // of the GLB bytes (etag_of)
  nlohmann::json camera;         // the keyframe's capture camera in its own frame (service/mission_scene.h)

  // {"mission","seq","bytes","triangles","captured","received","available"}: the POST answer and the event data.
  nlohmann::json answer() const;
  // {"seq","pose":[7],"bytes","triangles","captured","received","available"}: an entry of GET /v1/missions/{name}.
  nlohmann::json entry() const;
};

struct MissionSummary {
  std::string name;
  size_t keyframes = 0;
  std::uint64_t bytes = 0;
  double updated = 0.0;  // the newest "received", Unix s
};

enum class PutOutcome { kCreated, kSame, kConflict };

struct PutResult {
  PutOutcome outcome = PutOutcome::kCreated;
  MissionKeyframe keyframe;  // the stored one (for kSame and kConflict: what was stored first)
};

// Where an event stream stands: `next` indexes the mission's arrival order; `generation` changes when the mission is
// deleted (and maybe made again), which ends the stream.
struct EventCursor {
  std::uint64_t generation = 0;
  size_t next = 0;
};

struct EventBatch {
  bool exists = false;                   // false: no such mission (or deleted since the cursor was made)
  std::vector<MissionKeyframe> events;   // available keyframes from the cursor on, in arrival order
};

class MissionStore {
 public:
  static Result<std::unique_ptr<MissionStore>> open(const std::string& data_dir);
  ~MissionStore();

  // `keyframe` carries mission, seq, pose, triangles, captured, received and camera; bytes and etag are taken from
  // `glb`. kInvalidArgument for a bad name or seq, kIo when a write fails (nothing is left behind).
  Result<PutResult> put(MissionKeyframe keyframe, const std::vector<std::uint8_t>& glb);
  // Records when views include the keyframe (rewrites its JSON atomically) and wakes the event streams.
  Status mark_available(const std::string& name, std::int64_t seq, double available_unix_s);

  std::vector<MissionSummary> list() const;  // by name
  // Keyframes by seq; nullopt for an unknown mission.
  std::optional<std::vector<MissionKeyframe>> keyframes(const std::string& name) const;
  // Available keyframes in arrival order.
  std::optional<std::vector<MissionKeyframe>> arrivals(const std::string& name) const;
  Result<std::vector<std::uint8_t>> read_glb(const std::string& name, std::int64_t seq) const;
  Status remove(const std::string& name);  // kNotFound when unknown

  // A cursor just after the event with id `last_event_id` (the keyframe of that seq in arrival order), or at the
  // start when the id is absent or not a keyframe of the mission. nullopt for an unknown mission.
  std::optional<EventCursor> cursor_after(const std::string& name, std::optional<std::int64_t> last_event_id) const;
  // Waits up to `timeout` for events at the cursor and advances it past what it returns. Returns early, with
  // exists = false, when the mission goes away; returns at once once wake_all() was called.
  EventBatch wait_events(const std::string& name, EventCursor& cursor, std::chrono::milliseconds timeout);
  void wake_all();  // the server is stopping: every wait_events returns, now and from now on

  size_t count() const;
  const std::vector<std::string>& cleaned_on_open() const { return cleaned_; }
  const std::vector<std::string>& quarantined() const { return quarantined_; }

 private:
  struct Mission {
    std::uint64_t generation = 0;
    std::map<std::int64_t, MissionKeyframe> by_seq;
    std::vector<std::int64_t> arrival;  // seqs of available keyframes
  };
  explicit MissionStore(std::string data_dir, std::string missions_dir)
      : data_dir_(std::move(data_dir)), dir_(std::move(missions_dir)) {}
  std::string mission_dir(const std::string& name) const { return dir_ + "/" + name; }
  Status load_mission(const std::string& name);

  std::string data_dir_, dir_;
  std::mutex write_mutex_;  // one writer at a time (put, mark_available, remove)
  mutable std::mutex mutex_;  // the maps below
  std::condition_variable changed_;
  std::map<std::string, Mission> missions_;
  std::uint64_t next_generation_ = 1;
  bool stopped_ = false;  // wake_all() was called
  std::vector<std::string> cleaned_;
  std::vector<std::string> quarantined_;
};

}  // namespace rgbdcast::service
