#include "pgstore/pg_mission_store.h"

#include "base/stopwatch.h"
#include "pgstore/pg_mission_listener.h"
#include "pgstore/pg_schema.h"
#include "service/mission_index.h"
#include "service/scene_store.h"  // etag_of

namespace rgbdcast::pgstore {

using service::MissionKeyframe;
using service::PutOutcome;
using service::PutResult;

namespace {

// A write that found nothing to change: rolled back, and not an error for the caller.
constexpr const char* kUnchanged = "unchanged";
bool is_unchanged(const Status& st) {
  return !st && st.error().code == ErrorCode::kEmpty && st.error().message == kUnchanged;
}
Status unchanged() { return make_error(ErrorCode::kEmpty, kUnchanged); }

// The first statement of every mission write: the next change number, and the lock that orders the writes.
Result<std::int64_t> next_change(PgConnection& c) {
  auto r = c.exec("UPDATE change_clock SET last = last + 1 WHERE id = 1 RETURNING last");
  if (!r) return r.error();
  return r->integer(0, 0);
}

Status log_change(PgConnection& c, std::int64_t change, const std::string& mission, const char* kind,
                  std::optional<std::int64_t> seq, const std::string& record) {
  auto st = c.run("INSERT INTO mission_changes (change, mission, kind, seq, record) VALUES ($1, $2, $3, $4, $5)",
                  {PgParam::integer(change), PgParam::text(mission), PgParam::text(kind),
                   seq ? PgParam::integer(*seq) : PgParam::null(), PgParam::text(record)});
  if (!st) return st;
  return c.run("SELECT pg_notify($1, $2)", {PgParam::text(kMissionChannel), PgParam::integer(change)});
}

}  // namespace

Result<std::unique_ptr<PgMissionStore>> PgMissionStore::open(const std::string& uri, size_t connections,
                                                             double poll_interval_s) {
  auto pool = open_migrated_pool(uri, connections);
  if (!pool) return pool.error();
  std::unique_ptr<PgMissionStore> store(new PgMissionStore(std::move(*pool)));
  if (auto st = store->load_all(); !st) return st.error();
  store->listener_ = std::make_unique<PgMissionListener>(uri, *store, poll_interval_s);
  return store;
}

PgMissionStore::PgMissionStore(std::unique_ptr<PgPool> pool) : pool_(std::move(pool)) {}

PgMissionStore::~PgMissionStore() {
  listener_.reset();  // first: it applies changes to this store
  wake_all();
}

Status PgMissionStore::load_all() {
  auto conn = pool_->lease();
  if (!conn) return conn.error();
  std::int64_t last = 0;
  std::map<std::string, std::map<std::int64_t, MissionKeyframe>> missions;
  std::map<std::string, std::int64_t> created;
  // One snapshot: the rows and the change number they stand at.
  Status st = in_transaction(
      **conn,
      [&](PgConnection& c) -> Status {
        auto clock = c.exec("SELECT last FROM change_clock WHERE id = 1");
        if (!clock) return clock.error();
        last = clock->integer(0, 0);
        auto names = c.exec("SELECT name, created_change FROM missions");
        if (!names) return names.error();
        for (int i = 0; i < names->rows(); ++i) created[names->text(i, 0)] = names->integer(i, 1);
        auto rows = c.exec("SELECT mission, seq, record FROM keyframes");
        if (!rows) return rows.error();
        for (int i = 0; i < rows->rows(); ++i) {
          const std::string name = rows->text(i, 0);
          auto k = service::parse_stored_keyframe(name, rows->integer(i, 1), rows->text(i, 2));
          if (!k) return make_error(ErrorCode::kInvalidInput, "mission " + name + ": " + k.error().message);
          missions[name].emplace(k->seq, std::move(*k));
        }
        return ok_status();
      },
      "BEGIN ISOLATION LEVEL REPEATABLE READ READ ONLY");
  if (!st) return st;
  std::lock_guard lock(apply_mutex_);
  const double now = unix_seconds_now();
  for (auto& [name, by_seq] : missions) {
    created_change_[name] = created[name];
    index().load(name, std::move(by_seq), now);
  }
  applied_ = last;
  return ok_status();
}

void PgMissionStore::set_on_change(std::function<void(const std::string&)> f) {
  std::lock_guard lock(on_change_mutex_);
  on_change_ = std::move(f);
}

void PgMissionStore::apply(std::int64_t change, const std::string& mission, const std::string& kind, std::int64_t seq,
                           const std::string& record) {
  {
    std::lock_guard lock(apply_mutex_);
    if (change <= applied_) return;
    applied_ = change;
    if (kind == "remove") {
      auto it = created_change_.find(mission);
      if (it != created_change_.end() && it->second < change) {
        index().erase(mission);
        created_change_.erase(it);
      }
    } else {
      auto k = service::parse_stored_keyframe(mission, seq, record);
      if (!k) return;  // written by this program: cannot happen short of a hand edit, which is skipped
      if (!index().contains(mission)) created_change_[mission] = change;
      index().upsert(*k);
      if (k->available > 0) index().set_available(mission, seq, k->rev, k->available);
    }
  }
  // Called under the lock, so that set_on_change() returns only once no call of the former function is under way.
  std::lock_guard lock(on_change_mutex_);
  if (on_change_) on_change_(mission);
}

Status PgMissionStore::catch_up(PgConnection& conn) {
  while (true) {
    auto r = conn.exec(
        "SELECT change, mission, kind, coalesce(seq, -1), coalesce(record, '') FROM mission_changes "
        "WHERE change > $1 ORDER BY change LIMIT 1000",
        {PgParam::integer(applied_.load())});
    if (!r) return r.error();
    for (int i = 0; i < r->rows(); ++i)
      apply(r->integer(i, 0), r->text(i, 1), r->text(i, 2), r->integer(i, 3), r->text(i, 4));
    if (r->rows() < 1000) return ok_status();
  }
}

Result<PutResult> PgMissionStore::put(MissionKeyframe k, const std::vector<std::uint8_t>& glb) {
  if (auto st = service::check_keyframe_key(k); !st) return st.error();
  k.bytes = glb.size();
  k.etag = service::etag_of(glb.data(), glb.size());
  k.available = 0.0;
  k.first_available = 0.0;
  auto conn = pool_->lease();
  if (!conn) return conn.error();
  PutResult out{PutOutcome::kCreated, k};
  Status st = in_transaction(**conn, [&](PgConnection& c) -> Status {
    auto change = next_change(c);
    if (!change) return change.error();
    auto held = c.exec("SELECT rev, record, glb = $3 FROM keyframes WHERE mission = $1 AND seq = $2",
                       {PgParam::text(k.mission), PgParam::integer(k.seq), PgParam::bytes(glb.data(), glb.size())});
    if (!held) return held.error();
    if (held->rows() > 0) {
      auto stored = service::parse_stored_keyframe(k.mission, k.seq, held->text(0, 1));
      if (!stored) return make_error(ErrorCode::kInternal, "stored keyframe: " + stored.error().message);
      if (k.rev <= stored->rev) {
        const bool same_bytes = k.rev == stored->rev && held->text(0, 2) == "t";
        out = PutResult{service::repeat_outcome(*stored, k, same_bytes), *stored};
        return unchanged();
      }
      k.first_available = stored->first_available;  // a revision: the seq was viewable since then
      out.outcome = PutOutcome::kReplaced;
      if (auto s = c.run("DELETE FROM keyframes WHERE mission = $1 AND seq = $2",
                         {PgParam::text(k.mission), PgParam::integer(k.seq)});
          !s)
        return s;
    }
    if (auto s = c.run("INSERT INTO missions (name, created_change) VALUES ($1, $2) ON CONFLICT (name) DO NOTHING",
                       {PgParam::text(k.mission), PgParam::integer(*change)});
        !s)
      return s;
    const std::string record = service::stored_keyframe_json(k).dump();
    auto inserted = c.exec(
        "INSERT INTO keyframes (mission, seq, rev, record, glb, change) VALUES ($1, $2, $3, $4, $5, $6) "
        "ON CONFLICT ON CONSTRAINT keyframes_once DO NOTHING",
        {PgParam::text(k.mission), PgParam::integer(k.seq), PgParam::integer(k.rev), PgParam::text(record),
         PgParam::bytes(glb.data(), glb.size()), PgParam::integer(*change)});
    if (!inserted) return inserted.error();
    if (inserted->affected() != 1) return make_error(ErrorCode::kInternal, "keyframe stored meanwhile");
    out.keyframe = k;
    return log_change(c, *change, k.mission, "put", k.seq, record);
  });
  if (!st && !is_unchanged(st)) return st.error();
  if (st) (void)catch_up(**conn);  // this replica sees its own write at once (and whatever came before it)
  return out;
}

Status PgMissionStore::mark_available(const std::string& name, std::int64_t seq, double available_unix_s) {
  auto conn = pool_->lease();
  if (!conn) return conn.error();
  Status st = in_transaction(**conn, [&](PgConnection& c) -> Status {
    auto change = next_change(c);
    if (!change) return change.error();
    auto held = c.exec("SELECT record FROM keyframes WHERE mission = $1 AND seq = $2",
                       {PgParam::text(name), PgParam::integer(seq)});
    if (!held) return held.error();
    if (held->rows() == 0)
      return make_error(ErrorCode::kNotFound, "no keyframe " + std::to_string(seq) + " in mission " + name);
    auto k = service::parse_stored_keyframe(name, seq, held->text(0, 0));
    if (!k) return make_error(ErrorCode::kInternal, "stored keyframe: " + k.error().message);
    if (k->available > 0) return unchanged();
    k->available = available_unix_s;
    if (k->first_available <= 0) k->first_available = available_unix_s;
    const std::string record = service::stored_keyframe_json(*k).dump();
    if (auto s = c.run("UPDATE keyframes SET record = $3, change = $4 WHERE mission = $1 AND seq = $2",
                       {PgParam::text(name), PgParam::integer(seq), PgParam::text(record), PgParam::integer(*change)});
        !s)
      return s;
    return log_change(c, *change, name, "available", seq, record);
  });
  if (is_unchanged(st)) return ok_status();
  if (!st) return st;
  return catch_up(**conn);
}

Result<std::vector<std::uint8_t>> PgMissionStore::read_glb(const std::string& name, std::int64_t seq,
                                                           std::int64_t rev) const {
  auto missing = [&] {
    return make_error(ErrorCode::kNotFound, "no keyframe " + std::to_string(seq) + " revision " + std::to_string(rev) +
                                                " in mission " + name);
  };
  if (!service::is_valid_mission_name(name)) return missing();
  auto conn = pool_->lease();
  if (!conn) return conn.error();
  auto r = (*conn)->exec("SELECT glb FROM keyframes WHERE mission = $1 AND seq = $2 AND rev = $3",
                         {PgParam::text(name), PgParam::integer(seq), PgParam::integer(rev)}, /*binary_result=*/true);
  if (!r) return r.error();
  if (r->rows() == 0) return missing();
  return r->bytes(0, 0);
}

Status PgMissionStore::remove(const std::string& name) {
  if (!service::is_valid_mission_name(name)) return make_error(ErrorCode::kNotFound, "no mission " + name);
  auto conn = pool_->lease();
  if (!conn) return conn.error();
  Status st = in_transaction(**conn, [&](PgConnection& c) -> Status {
    auto change = next_change(c);
    if (!change) return change.error();
    auto gone = c.exec("DELETE FROM missions WHERE name = $1", {PgParam::text(name)});  // cascades to keyframes
    if (!gone) return gone.error();
    if (gone->affected() == 0) return make_error(ErrorCode::kNotFound, "no mission " + name);
    return log_change(c, *change, name, "remove", std::nullopt, "");
  });
  if (!st) return st;
  return catch_up(**conn);
}

Status PgMissionStore::ping() const { return pool_->ping(); }

}  // namespace rgbdcast::pgstore
