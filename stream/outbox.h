#pragma once
// The sender's on-disk outbox: every keyframe is written here before it is sent, so nothing is lost when the link,
// the server or the sender itself goes away, and a restarted sender resumes where it stopped.
//
// Layout of DIR: `mission.json` ({"mission": name}: an outbox serves one mission), and per keyframe
// `kf-<seq, 8 digits>.glb` (the body exactly as posted; `kf-<seq>.r<rev>.glb` for a revision rev > 0) and
// `kf-<seq>.json` (its state, below). Each file is written
// by the project's one atomic writer (base/atomic_file.h: temp file, fsync, rename), the GLB before its JSON: an
// entry exists when its JSON does; a GLB without one (a crash between the two writes) was never sent and is
// removed when the outbox is opened. Sequence numbers continue after the highest one on disk.
//
// States: queued -> attempted (persisted before the first POST: from then on its bytes never change, since the
// server may already hold them; only a never-attempted entry may be coarsened) -> acked (the server's answer kept)
// or rejected (a 4xx other than 409 that retrying cannot fix; kept with the reason, counted as lost).
// Revisions: an acked entry may be revised (a refinement: the same keyframe reduced again at a larger budget, posted
// with rev + 1, which the server stores in place of the older one). revise() writes the new GLB under its own name,
// then the JSON (the commit: rev + 1, queued again), then removes the older GLB; open() removes a GLB that is not
// its entry's current revision. The entry keeps its first revision's answer and size (first_ack, first_bytes).
// An attempted entry whose answer has not come may be revised too (revise_in_flight): the new revision is posted
// beside the one in flight, and the server keeps the higher rev whichever arrives first (an older one arriving later
// is answered 409 stale_revision, which the sender counts as stored). The answer to the older revision then only
// fills first_ack (rev 0's) and never acknowledges the newer one: mark_attempted, mark_acked and mark_rejected take
// the revision they are about and leave a newer one as it is.
// Deferred keyframes (the backlog rule's, stream/keyframe_stream.h: tracked, not reduced yet, so no GLB and no seq:
// a seq is given when the keyframe is reduced and added) are kept as `deferred-<frame, 8 digits>.json` records, by
// the same atomic writer, so that a stop does not lose them: a restarted sender reduces them from their frames.
// add() removes the record of the keyframe it adds (after its JSON, the commit), and open() removes a record whose
// frame already has an entry (a crash between the two), so a keyframe is either deferred or an entry, never both.
// Thread-safe: one mutex around the index; file writes happen under it (they are small and rare).
#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "scene/result.h"

namespace rgbdcast::stream {

struct OutboxEntry {
  int seq = -1;
  int frame_index = -1;          // in the input source
  double timestamp = 0;          // the frame's own timestamp (s; 0 when the source has none)
  std::array<double, 7> pose{};  // camera to world, TUM order tx ty tz qx qy qz qw
  double captured = 0;           // Unix s
  // Where the time of a keyframe goes (Unix s; 0 when not known, e.g. an outbox written before they were kept):
  double tracked = 0;       // the tracker had its pose (its budget was chosen then)
  double reduced = 0;       // its GLB was ready (written to the outbox)
  double post_started = 0;  // its first POST started
  double budget_kb = 0;     // the budget it was reduced to (the coarser one once coarsened)
  size_t bytes = 0;         // of the GLB on disk
  size_t triangles = 0;
  bool coarsened = false;
  int rev = 0;                 // the revision now in the outbox (0: the keyframe as first sent)
  size_t first_bytes = 0;      // of revision 0 (0 while rev == 0: then it is `bytes`)
  double first_budget_kb = 0;  // of revision 0 (0 while rev == 0: then it is `budget_kb`)
  std::string first_ack;       // the server's answer to revision 0 (empty while rev == 0: then it is ack_json)
  bool attempted = false;
  bool acked = false;
  std::string rejected;  // non-empty: the server refused it for good (the reason)
  std::string ack_json;  // the server's answer (acked)
  bool pending() const { return !acked && rejected.empty(); }
};

// A deferred keyframe's record: what reducing it later needs besides its frame (re-read from the source) and the
// coverage views (the entries before it).
struct DeferredKeyframe {
  int frame_index = -1;          // in the input source
  double timestamp = 0;          // the frame's own timestamp (s; 0 when the source has none)
  std::array<double, 7> pose{};  // camera to world in the mission's world, TUM order tx ty tz qx qy qz qw
  double captured = 0;           // Unix s
  double tracked = 0;            // Unix s
};

class Outbox {
 public:
  // Opens (creating when missing) DIR for `mission`. Errors: kInvalidArgument (DIR holds another mission),
  // kInvalidInput (an unreadable entry: the file is named), kIo.
  static Result<std::unique_ptr<Outbox>> open(const std::string& dir, const std::string& mission);

  const std::string& dir() const { return dir_; }
  std::vector<OutboxEntry> entries() const;  // by seq
  std::optional<OutboxEntry> entry(int seq) const;
  int next_seq() const;
  // Writes a new entry (seq assigned: next_seq()) and returns it.
  Result<OutboxEntry> add(OutboxEntry entry, const std::vector<std::uint8_t>& glb);
  // Replaces a never-attempted entry's GLB by a coarser one (kInvalidArgument when it was attempted, or is a
  // refinement: rev > 0).
  Status coarsen(int seq, const std::vector<std::uint8_t>& glb, double budget_kb, size_t triangles);
  // An acked entry's next revision (rev + 1, queued again; kInvalidArgument when the entry is not acked).
  Status revise(int seq, const std::vector<std::uint8_t>& glb, double budget_kb, size_t triangles);
  // The same for an entry whose POST is out (attempted, not answered, not rejected; kInvalidArgument otherwise).
  Status revise_in_flight(int seq, const std::vector<std::uint8_t>& glb, double budget_kb, size_t triangles);
  // Persisted before the first POST; post_started (Unix s) is kept from the first attempt. `rev`: the revision the
  // call is about (-1: the current one); when the entry holds a newer revision, mark_attempted and mark_rejected
  // change nothing and mark_acked only keeps a rev 0 answer as first_ack.
  Status mark_attempted(int seq, double post_started = 0, int rev = -1);
  Status mark_acked(int seq, const std::string& ack_json, int rev = -1);
  Status mark_rejected(int seq, const std::string& reason, int rev = -1);
  Result<std::vector<std::uint8_t>> read_glb(int seq) const;
  // One revision's GLB (kNotFound once a newer revision replaced it).
  Result<std::vector<std::uint8_t>> read_glb(int seq, int rev) const;

  // Deferred keyframes: defer() persists a record (replacing one of the same frame); undefer() removes it (when it
  // was dropped, or its reduction left nothing to add; no error when there is none); deferred() lists them by frame.
  Status defer(const DeferredKeyframe& keyframe);
  Status undefer(int frame_index);
  std::vector<DeferredKeyframe> deferred() const;

 private:
  Outbox(std::string dir, std::string mission) : dir_(std::move(dir)), mission_(std::move(mission)) {}
  std::string path(int seq, const char* ext) const;
  std::string glb_path(int seq, int rev) const;
  std::string deferred_path(int frame_index) const;
  Status remove_deferred_locked(int frame_index);
  Status write_meta(const OutboxEntry& e) const;
  Status update(int seq, const std::function<void(OutboxEntry&)>& change);
  // revise()'s body; `in_flight`: the entry is attempted and unanswered instead of acked.
  Status revise_entry(int seq, const std::vector<std::uint8_t>& glb, double budget_kb, size_t triangles,
                      bool in_flight);

  std::string dir_, mission_;
  mutable std::mutex mu_;
  std::map<int, OutboxEntry> entries_;
  std::map<int, DeferredKeyframe> deferred_;  // by frame index
};

// The 4x4 camera-to-world matrix as TUM's 7 numbers (unit quaternion, qw >= 0), and the query text "a,b,..."
// the missions contract asks for.
std::array<double, 7> pose_to_tum(const double* column_major_4x4);
std::string pose_query(const std::array<double, 7>& pose);

}  // namespace rgbdcast::stream
