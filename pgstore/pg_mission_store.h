#pragma once
// Live missions as rows of PostgreSQL (pgstore/pg_schema.h), shared by every replica on the same database.
// MissionStore's contract (service/mission_store.h); besides it:
// - Every write is one transaction that first increments change_clock (so mission writes are serialized and their
//   change numbers commit in order), writes the keyframe row (unique on (mission, seq, rev): the idempotency key),
//   appends the change to mission_changes, and NOTIFYs kMissionChannel, delivered at commit.
// - put() decides kSame / kConflict / kStale against the row in the database, whichever replica stored it; a
//   revision deletes the older revision's row in the same transaction.
// - Each replica keeps the missions in memory (the index the event streams wait on) and a listener
//   (pgstore/pg_mission_listener.h) on its own connection applies every change of mission_changes after the last
//   one it applied: NOTIFY is only the hint to look now; after a reconnect (or every poll interval) it catches up
//   by change number, so a change is never missed and never applied twice.
// - on_change (when set) is called with a mission's name after each change applied, whichever replica made it (the
//   tile worker follows it; naming a mission twice is harmless). It must be quick and must not call set_on_change:
//   it runs under the lock that set_on_change takes, so that clearing it waits for a call under way.
#include <atomic>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "pgstore/pg_connection.h"
#include "service/mission_store.h"

namespace rgbdcast::pgstore {

class PgMissionListener;

class PgMissionStore final : public service::MissionStore {
 public:
  static Result<std::unique_ptr<PgMissionStore>> open(const std::string& uri, size_t connections = 8,
                                                      double poll_interval_s = 2.0);
  ~PgMissionStore() override;

  Result<service::PutResult> put(service::MissionKeyframe keyframe, const std::vector<std::uint8_t>& glb) override;
  Status mark_available(const std::string& name, std::int64_t seq, double available_unix_s) override;
  Result<std::vector<std::uint8_t>> read_glb(const std::string& name, std::int64_t seq,
                                             std::int64_t rev = 0) const override;
  Status remove(const std::string& name) override;
  Status ping() const override;

  void set_on_change(std::function<void(const std::string&)> f);
  // The last change number this replica has applied (tests: every replica reaches the same one).
  std::int64_t applied_change() const { return applied_.load(); }
  // Applies every change after the last applied one now (what the listener does on a NOTIFY).
  Status catch_up(PgConnection& conn);

 private:
  explicit PgMissionStore(std::unique_ptr<PgPool> pool);
  Status load_all();
  void apply(std::int64_t change, const std::string& mission, const std::string& kind, std::int64_t seq,
             const std::string& record);

  std::unique_ptr<PgPool> pool_;
  std::mutex apply_mutex_;  // changes are applied in change order, one at a time
  std::atomic<std::int64_t> applied_{0};
  std::map<std::string, std::int64_t> created_change_;  // per mission in the index: the change that made it
  std::mutex on_change_mutex_;
  std::function<void(const std::string&)> on_change_;
  std::unique_ptr<PgMissionListener> listener_;
};

}  // namespace rgbdcast::pgstore
