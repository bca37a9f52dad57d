#pragma once
// Live missions on disk: <data_dir>/missions/<name>/<seq>.glb (the keyframe GLB as the robot sent it;
// <seq>.r<rev>.glb for a revision rev > 0) and <seq>.json (its pose, sizes, times and rev). Contract:
// - put() writes the GLB, then the JSON, each with write_file_atomic (service/scene_store.h: temporary name, fsync,
//   rename, fsync of the folder); the JSON is the commit marker, so a crash leaves a whole keyframe or none.
// - Idempotency key (name, seq, rev): a put() of the stored (seq, rev) with the same GLB bytes and the same pose is
//   kSame (nothing written, the stored keyframe returned); with other bytes or another pose kConflict (nothing
//   written).
// - Revisions: a put() of a stored seq with a higher rev REPLACES that keyframe (kReplaced): the new GLB is written
//   under its own name, then the JSON (the commit: from then on the new rev is the keyframe), then the old GLB is
//   removed; a crash leaves the old revision or the new one, never both and never neither. A lower rev than the
//   stored one is kStale (nothing written). The mission holds one keyframe (one surface) per seq, always.
//   "first_available" keeps when the seq's first revision became viewable (the capture-to-view latency is that).
// - A keyframe is put() first and mark_available() once views include it; only available keyframes are events.
//   Events are in arrival order (the order keyframes became available), which is seq order only when the sender sends
//   in seq order; a revision is an event of its own (the same seq with a higher rev); after a restart the order is
//   rebuilt from the stored "available" times, one event per keyframe (its current revision).
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
  std::int64_t rev = 0;          // revision: a higher one replaced the keyframe of this seq (0: the first)
  std::array<double, 7> pose{};  // tx ty tz qx qy qz qw: camera-to-world, OpenCV camera convention (as posted)
  std::uint64_t bytes = 0;       // of the GLB
  std::uint64_t triangles = 0;
  double captured = 0.0;         // the sender's capture time, Unix s
  double received = 0.0;         // when the POST arrived, Unix s
  double available = 0.0;        // when views include it, Unix s; 0 until mark_available()
  double first_available = 0.0;  // when views first included this seq (its first revision), Unix s
  std::string etag;              // of the GLB bytes (etag_of)
  nlohmann::json camera;         // the keyframe's capture camera in its own frame (service/mission_scene.h)

  // {"mission","seq","rev","bytes","triangles","captured","received","available","first_available"}: the POST answer
  // and the event data.
  nlohmann::json answer() const;
  // {"seq","rev","pose":[7],"bytes","triangles","captured","received","available","first_available"}: an entry of
  // GET /v1/missions/{name}.
  nlohmann::json entry() const;
  // The SSE event id: "<seq>" for rev 0, "<seq>-<rev>" for a revision.
  std::string event_id() const;
};

struct MissionSummary {
  std::string name;
  size_t keyframes = 0;
  std::uint64_t bytes = 0;
  double updated = 0.0;  // the newest "received", Unix s
};

enum class PutOutcome { kCreated, kSame, kConflict, kReplaced, kStale };

struct PutResult {
  PutOutcome outcome = PutOutcome::kCreated;
  MissionKeyframe keyframe;  // the stored one (for kSame, kConflict and kStale: what was stored before)
};

// An event id as a client sends it back (Last-Event-ID): "<seq>" or "<seq>-<rev>".
struct MissionEventId {
  std::int64_t seq = 0, rev = 0;
};
std::optional<MissionEventId> parse_event_id(const std::string& text);

// Where an event stream stands: `next` indexes the mission's arrival order; `generation` changes when the mission is
// deleted (and maybe made again), which ends the stream.
struct EventCursor {
  std::uint64_t generation = 0;
  size_t next = 0;
  std::uint64_t tileset_version = 0;  // the mission's tileset version this stream last reported (0: none yet)
};

struct EventBatch {
  bool exists = false;                   // false: no such mission (or deleted since the cursor was made)
  std::vector<MissionKeyframe> events;   // available keyframes from the cursor on, in arrival order
  std::optional<std::uint64_t> tileset_version;  // set when the tileset changed since the cursor's
};

class MissionStore {
 public:
  static Result<std::unique_ptr<MissionStore>> open(const std::string& data_dir);
  ~MissionStore();

  // `keyframe` carries mission, seq, rev, pose, triangles, captured, received and camera; bytes and etag are taken
  // from `glb`. kInvalidArgument for a bad name, seq or rev, kIo when a write fails (nothing is left behind).
  Result<PutResult> put(MissionKeyframe keyframe, const std::vector<std::uint8_t>& glb);
  // Records when views include the keyframe (rewrites its JSON atomically) and wakes the event streams.
  Status mark_available(const std::string& name, std::int64_t seq, double available_unix_s);
  // The mission's tile hierarchy (service/mission_tiles.h) committed `version`: wakes the event streams, which report
  // it once. Kept in memory only (the hierarchy holds its own version); ignored for an unknown mission.
  void set_tileset_version(const std::string& name, std::uint64_t version);

  std::vector<MissionSummary> list() const;  // by name
  // Keyframes by seq; nullopt for an unknown mission.
  std::optional<std::vector<MissionKeyframe>> keyframes(const std::string& name) const;
  // Available keyframes in arrival order.
  std::optional<std::vector<MissionKeyframe>> arrivals(const std::string& name) const;
  // The GLB of (seq, rev): kNotFound when that revision is not (or no longer) stored.
  Result<std::vector<std::uint8_t>> read_glb(const std::string& name, std::int64_t seq, std::int64_t rev = 0) const;
  Status remove(const std::string& name);  // kNotFound when unknown

  // A cursor just after the event with id `last_event_id` (that (seq, rev) in arrival order), or at the start when
  // the id is absent or not an event of the mission (e.g. a revision from before a restart). nullopt for an unknown
  // mission.
  std::optional<EventCursor> cursor_after(const std::string& name, std::optional<MissionEventId> last_event_id) const;
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
    std::vector<MissionKeyframe> arrival;  // available keyframes (each revision as it became available)
    std::uint64_t tileset_version = 0;
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
