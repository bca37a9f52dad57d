#include "pgstore/pg_tile_storage.h"

#include <functional>

#include "base/atomic_file.h"
#include "pgstore/pg_schema.h"

namespace rgbdcast::pgstore {
namespace {

// A text[] literal of `items` (each quoted, so any text is one element).
std::string text_array(const std::set<std::string>& items) {
  std::string out = "{";
  for (const auto& item : items) {
    if (out.size() > 1) out += ',';
    out += '"';
    for (char ch : item) {
      if (ch == '"' || ch == '\\') out += '\\';
      out += ch;
    }
    out += '"';
  }
  return out + "}";
}

// The mission's hierarchy row, made when missing (version 0: nothing committed) and locked for this transaction.
// Returns its version.
Result<std::uint64_t> lock_hierarchy(PgConnection& conn, const PgParam& mission) {
  if (auto st = conn.run("INSERT INTO tile_hierarchies (mission, record) VALUES ($1, ''::bytea) "
                         "ON CONFLICT (mission) DO NOTHING",
                         {mission});
      !st)
    return st.error();
  auto r = conn.exec("SELECT version FROM tile_hierarchies WHERE mission = $1 FOR UPDATE", {mission});
  if (!r) return r.error();
  if (r->rows() == 0) return make_error(ErrorCode::kNotFound, "postgresql: the tile hierarchy's row went away");
  return static_cast<std::uint64_t>(r->integer(0, 0));
}

class PgTileStorage final : public tiles::TileStorage {
 public:
  PgTileStorage(std::shared_ptr<PgPool> pool, std::string mission, std::string cache_dir,
                std::unique_ptr<tiles::TileStorage> cache)
      : pool_(std::move(pool)),
        mission_(std::move(mission)),
        cache_dir_(std::move(cache_dir)),
        cache_(std::move(cache)) {}

  Result<std::optional<tiles::TileRecordBytes>> read_record() override {
    auto conn = pool_->lease();
    if (!conn) return conn.error();
    auto r = (*conn)->exec("SELECT record, version::text FROM tile_hierarchies WHERE mission = $1 AND version > 0",
                           {PgParam::text(mission_)}, /*binary_result=*/true);
    if (!r) return r.error();
    if (r->rows() == 0) return std::optional<tiles::TileRecordBytes>();
    return std::optional<tiles::TileRecordBytes>(
        tiles::TileRecordBytes{static_cast<std::uint64_t>(r->integer(0, 1)), r->bytes(0, 0)});
  }

  Result<std::uint64_t> committed_version() override {
    auto conn = pool_->lease();
    if (!conn) return conn.error();
    auto r = (*conn)->exec("SELECT version FROM tile_hierarchies WHERE mission = $1", {PgParam::text(mission_)});
    if (!r) return r.error();
    return r->rows() == 0 ? 0 : static_cast<std::uint64_t>(r->integer(0, 0));
  }

  Status write_tile(const std::string& file, const std::vector<std::uint8_t>& bytes) override {
    auto conn = pool_->lease();
    if (!conn) return conn.error();
    const std::vector<PgParam> params = {PgParam::text(mission_), PgParam::text(file),
                                         PgParam::bytes(bytes.data(), bytes.size())};
    // A file the committed record keeps stays as it is; an uncommitted one (a cut or refused update's) is replaced.
    auto r = (*conn)->exec(
        "INSERT INTO tiles (mission, file, bytes) VALUES ($1, $2, $3) ON CONFLICT (mission, file) "
        "DO UPDATE SET bytes = EXCLUDED.bytes WHERE NOT tiles.file = ANY(coalesce("
        "(SELECT keep FROM tile_hierarchies WHERE mission = $1), '{}'))",
        params);
    if (!r) return r.error();
    if (r->affected() > 0) (void)write_file_atomically(cache_dir_ + "/" + file, bytes);  // a miss is fetched again
    return ok_status();
  }

  Result<std::vector<std::uint8_t>> read_tile(const std::string& file) const override {
    if (auto cached = cache_->read_tile(file)) return cached;
    auto conn = pool_->lease();
    if (!conn) return conn.error();
    auto r = (*conn)->exec("SELECT bytes FROM tiles WHERE mission = $1 AND file = $2",
                           {PgParam::text(mission_), PgParam::text(file)}, /*binary_result=*/true);
    if (!r) return r.error();
    if (r->rows() == 0) return make_error(ErrorCode::kNotFound, "no tile " + file + " in mission " + mission_);
    auto bytes = r->bytes(0, 0);
    (void)write_file_atomically(cache_dir_ + "/" + file, bytes);
    return bytes;
  }

  Result<std::string> local_file(const std::string& file) const override {
    if (auto path = cache_->local_file(file)) return path;
    auto bytes = read_tile(file);
    if (!bytes) return bytes.error();
    return cache_->local_file(file);
  }

  // f(transaction, mission, committed version) in one transaction that holds the mission's row lock.
  Status locked(const std::function<Status(PgConnection&, const PgParam&, std::uint64_t)>& f) {
    auto conn = pool_->lease();
    if (!conn) return conn.error();
    const PgParam mission = PgParam::text(mission_);
    return in_transaction(**conn, [&](PgConnection& t) -> Status {
      auto version = lock_hierarchy(t, mission);
      if (!version) return version.error();
      return f(t, mission, *version);
    });
  }

  Result<bool> commit(const tiles::TileCommit& c) override;
  Status delete_tiles(const std::set<std::string>& files) override;
  Status collect(const std::set<std::string>& named, std::uint64_t committed_version) override;
  Status remove() override;
  std::string where() const override { return "postgresql tiles of mission " + mission_; }

 private:
  std::shared_ptr<PgPool> pool_;
  std::string mission_, cache_dir_;
  std::unique_ptr<tiles::TileStorage> cache_;  // this machine's copy of the files
};

Result<bool> PgTileStorage::commit(const tiles::TileCommit& c) {
  bool refused = false;
  std::set<std::string> keep = c.retained, named_files;
  std::string sizes = "{";
  for (const auto& [f, size] : c.named) {
    keep.insert(f);
    named_files.insert(f);
    if (sizes.size() > 1) sizes += ',';
    sizes += std::to_string(size);
  }
  sizes += "}";
  Status st = locked([&](PgConnection& t, const PgParam& mission, std::uint64_t version) -> Status {
    auto stored = t.exec(
        "SELECT count(*) FROM tiles t JOIN unnest($2::text[], $3::bigint[]) AS n (file, size) "
        "ON t.file = n.file AND length(t.bytes) = n.size WHERE t.mission = $1",
        {mission, PgParam::text(text_array(named_files)), PgParam::text(sizes)});
    if (!stored) return stored.error();
    refused = version >= c.version || static_cast<size_t>(stored->integer(0, 0)) != c.named.size();
    if (refused) return make_error(ErrorCode::kInvalidInput, "refused");  // rolled back: nothing changes
    if (auto s = t.run("UPDATE tile_hierarchies SET record = $2, version = $3, keep = $4::text[] WHERE mission = $1",
                       {mission, PgParam::bytes(c.record.data(), c.record.size()),
                        PgParam::integer(static_cast<std::int64_t>(c.version)), PgParam::text(text_array(keep))});
        !s)
      return s;
    return t.run("DELETE FROM tiles WHERE mission = $1 AND file = ANY($2::text[]) AND NOT file = ANY($3::text[])",
                 {mission, PgParam::text(text_array(c.garbage)), PgParam::text(text_array(keep))});
  });
  if (refused) return false;
  if (!st) return st.error();
  std::set<std::string> gone;
  for (const auto& f : c.garbage)
    if (!keep.count(f)) gone.insert(f);
  (void)cache_->delete_tiles(gone);
  return true;
}

Status PgTileStorage::delete_tiles(const std::set<std::string>& files) {
  if (files.empty()) return ok_status();
  Status st = locked([&](PgConnection& t, const PgParam& mission, std::uint64_t) {
    return t.run(
        "DELETE FROM tiles WHERE mission = $1 AND file = ANY($2::text[]) AND NOT file = ANY(coalesce("
        "(SELECT keep FROM tile_hierarchies WHERE mission = $1), '{}'))",
        {mission, PgParam::text(text_array(files))});
  });
  (void)cache_->delete_tiles(files);
  return st;
}

Status PgTileStorage::collect(const std::set<std::string>& named, std::uint64_t committed_version) {
  Status st = locked([&](PgConnection& t, const PgParam& mission, std::uint64_t) {
    return t.run(
        "DELETE FROM tiles WHERE mission = $1 AND NOT file = ANY($2::text[]) AND NOT file = ANY(coalesce("
        "(SELECT keep FROM tile_hierarchies WHERE mission = $1), '{}')) AND "
        "coalesce(substring(file from '\\.v([0-9]{1,18})\\.glb$')::bigint, 0) <= $3",
        {mission, PgParam::text(text_array(named)), PgParam::integer(static_cast<std::int64_t>(committed_version))});
  });
  if (!st) return st;
  return cache_->collect(named, committed_version);
}

Status PgTileStorage::remove() {
  auto conn = pool_->lease();
  if (!conn) return conn.error();
  const PgParam mission = PgParam::text(mission_);
  Status st = in_transaction(**conn, [&](PgConnection& t) -> Status {
    const char* gone = " AND NOT EXISTS (SELECT 1 FROM missions WHERE name = $1)";
    if (auto s = t.run(std::string("DELETE FROM tiles WHERE mission = $1") + gone, {mission}); !s) return s;
    return t.run(std::string("DELETE FROM tile_hierarchies WHERE mission = $1") + gone, {mission});
  });
  (void)cache_->remove();
  return st;
}

}  // namespace

Result<std::unique_ptr<PgTileStores>> PgTileStores::open(const std::string& uri, size_t connections) {
  auto pool = open_migrated_pool(uri, connections);
  if (!pool) return pool.error();
  return std::unique_ptr<PgTileStores>(new PgTileStores(std::shared_ptr<PgPool>(std::move(*pool))));
}

Result<std::unique_ptr<tiles::TileStorage>> PgTileStores::storage(const std::string& mission,
                                                                  const std::string& cache_dir) const {
  auto cache = tiles::directory_tile_storage(cache_dir);
  if (!cache) return cache.error();
  return std::unique_ptr<tiles::TileStorage>(new PgTileStorage(pool_, mission, cache_dir, std::move(*cache)));
}

}  // namespace rgbdcast::pgstore
