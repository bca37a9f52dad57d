#pragma once
// Live missions: the MissionStore interface and its embedded default, the directory store.
// Names are [A-Za-z0-9_-]{1,64} and seqs 0..2^31-1, checked before they reach a path or a query.
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
  bool exists = false;                           // false: no such mission (or deleted since the cursor was made)
  std::vector<MissionKeyframe> events;           // available keyframes from the cursor on, in arrival order
  std::optional<std::uint64_t> tileset_version;  // set when the tileset changed since the cursor's
};

class MissionIndex;

// Where live missions live: the interface every store implements (the directory below, PostgreSQL in pgstore/),
// tested by one contract suite (tests/service/test_store_contract.cpp). Contract of every implementation:
// - Idempotency key (name, seq, rev): a put() of the stored (seq, rev) with the same GLB bytes and the same pose is
//   kSame (nothing written, the stored keyframe returned); with other bytes or another pose kConflict (nothing
//   written). A higher rev of a stored seq REPLACES that keyframe (kReplaced), atomically: readers see the old
//   revision or the new one, never both and never neither. A lower rev is kStale (nothing written). The mission
//   holds one keyframe (one surface) per seq, always. "first_available" keeps when the seq's first revision became
//   viewable (the capture-to-view latency is that).
// - A keyframe is put() first and mark_available() once views include it; only available keyframes are events.
//   Events are in arrival order (the order keyframes became available); a revision is an event of its own (the same
//   seq with a higher rev); after a restart the order is rebuilt from the stored "available" times, one event per
//   keyframe (its current revision).
// - Names are [A-Za-z0-9_-]{1,64} and seqs and revs 0..2^31-1 (else kInvalidArgument); kIo when storage fails
//   (nothing is left behind).
// Thread-safe: every method may be called from any thread.
class MissionStore {
 public:
  virtual ~MissionStore();
  // The embedded default: the directory store in <data_dir>/missions (DirectoryMissionStore).
  static Result<std::unique_ptr<MissionStore>> open(const std::string& data_dir);

  // `keyframe` carries mission, seq, rev, pose, triangles, captured, received and camera; bytes and etag are taken
  // from `glb`.
  virtual Result<PutResult> put(MissionKeyframe keyframe, const std::vector<std::uint8_t>& glb) = 0;
  // Records when views include the keyframe and wakes the event streams.
  virtual Status mark_available(const std::string& name, std::int64_t seq, double available_unix_s) = 0;
  // The GLB of (seq, rev): kNotFound when that revision is not (or no longer) stored.
  virtual Result<std::vector<std::uint8_t>> read_glb(const std::string& name, std::int64_t seq,
                                                     std::int64_t rev = 0) const = 0;
  virtual Status remove(const std::string& name) = 0;  // kNotFound when unknown

  // The mission's tile hierarchy (service/mission_tiles.h) committed `version`: wakes the event streams, which report
  // it once. Kept in memory only (the hierarchy holds its own version); ignored for an unknown mission.
  void set_tileset_version(const std::string& name, std::uint64_t version);
  std::vector<MissionSummary> list() const;  // by name
  // Keyframes by seq; nullopt for an unknown mission.
  std::optional<std::vector<MissionKeyframe>> keyframes(const std::string& name) const;
  // Available keyframes in arrival order.
  std::optional<std::vector<MissionKeyframe>> arrivals(const std::string& name) const;
  // A cursor just after the event with id `last_event_id` (that (seq, rev) in arrival order), or at the start when
  // the id is absent or not an event of the mission (e.g. a revision from before a restart). nullopt for an unknown
  // mission.
  std::optional<EventCursor> cursor_after(const std::string& name, std::optional<MissionEventId> last_event_id) const;
  // Waits up to `timeout` for events at the cursor and advances it past what it returns. Returns early, with
  // exists = false, when the mission goes away; returns at once once wake_all() was called.
  EventBatch wait_events(const std::string& name, EventCursor& cursor, std::chrono::milliseconds timeout);
  void wake_all();  // the server is stopping: every wait_events returns, now and from now on
  size_t count() const;

  // What opening the store removed (what a crash left) and set aside (damaged records), one line each.
  virtual const std::vector<std::string>& cleaned_on_open() const { return none_; }
  virtual const std::vector<std::string>& quarantined() const { return none_; }
  // Whether the store answers now (a database may be unreachable for a while): /readyz.
  virtual Status ping() const { return ok_status(); }

 protected:
  MissionStore();
  // What every implementation reads and waits on; it persists first, then tells the index.
  MissionIndex& index() const { return *index_; }

 private:
  std::unique_ptr<MissionIndex> index_;
  std::vector<std::string> none_;
};

// A keyframe's stored record (entry() with mission, etag and camera; available and first_available only once set),
// and the record read back: every field present with its type, or kInvalidInput with the reason.
nlohmann::json stored_keyframe_json(const MissionKeyframe& k);
Result<MissionKeyframe> parse_stored_keyframe(const std::string& name, std::int64_t seq, const std::string& text);
// Checks a put()'s key; kInvalidArgument with the reason.
Status check_keyframe_key(const MissionKeyframe& k);
// The outcome of a put() of `k` against the stored revision of its seq, when the rev is not higher (kStale, or kSame
// / kConflict as `same_bytes` says about the stored GLB of that rev).
PutOutcome repeat_outcome(const MissionKeyframe& stored, const MissionKeyframe& k, bool same_bytes);

// Live missions on disk: <data_dir>/missions/<name>/<seq>.glb (the keyframe GLB as the robot sent it;
// <seq>.r<rev>.glb for a revision rev > 0) and <seq>.json (its pose, sizes, times and rev). Besides MissionStore's
// contract:
// - put() writes the GLB, then the JSON, each with write_file_atomically (base/atomic_file.h: temporary name, fsync,
//   rename, fsync of the folder); the JSON is the commit marker, so a crash leaves a whole keyframe or none.
// - A revision's new GLB is written under its own name, then the JSON (the commit: from then on the new rev is the
//   keyframe), then the old GLB is removed.
// - open() deletes what an interrupted put() or remove() left (temporary files, a GLB without its JSON, a mission
//   folder being deleted), and moves a keyframe JSON that does not parse or has a field of the wrong type, with its
//   GLB, to <data_dir>/quarantine/mission-<name>-<seq>.json|.glb (one line each in quarantined()); the rest is served.
// - remove() renames the mission folder to a hidden name first (one atomic step), then deletes it.
// - Writes are serialized inside.
class DirectoryMissionStore final : public MissionStore {
 public:
  static Result<std::unique_ptr<DirectoryMissionStore>> open(const std::string& data_dir);
  ~DirectoryMissionStore() override;

  Result<PutResult> put(MissionKeyframe keyframe, const std::vector<std::uint8_t>& glb) override;
  Status mark_available(const std::string& name, std::int64_t seq, double available_unix_s) override;
  Result<std::vector<std::uint8_t>> read_glb(const std::string& name, std::int64_t seq,
                                             std::int64_t rev = 0) const override;
  Status remove(const std::string& name) override;
  const std::vector<std::string>& cleaned_on_open() const override { return cleaned_; }
  const std::vector<std::string>& quarantined() const override { return quarantined_; }

 private:
  DirectoryMissionStore(std::string data_dir, std::string missions_dir)
      : data_dir_(std::move(data_dir)), dir_(std::move(missions_dir)) {}
  std::string mission_dir(const std::string& name) const { return dir_ + "/" + name; }
  Status load_mission(const std::string& name);

  std::string data_dir_, dir_;
  std::mutex write_mutex_;  // one writer at a time (put, mark_available, remove)
  std::vector<std::string> cleaned_;
  std::vector<std::string> quarantined_;
};

}  // namespace rgbdcast::service
