#include "pgstore/pg_schema.h"

#include <array>

namespace rgbdcast::pgstore {
namespace {

// Append only: a released migration is never edited, a change is a new one.
constexpr std::array<const char*, 2> kMigrations = {
    // 1: scenes, missions with their keyframes and change log, tiles.
    R"sql(
CREATE TABLE scenes (
  id text PRIMARY KEY CHECK (id ~ '^[0-9a-f]{32}$'),
  created_unix_s double precision NOT NULL,
  bytes bigint NOT NULL,
  etag text NOT NULL,
  metadata text NOT NULL,
  glb bytea NOT NULL);
CREATE INDEX scenes_by_age ON scenes (created_unix_s, id);
CREATE TABLE change_clock (id integer PRIMARY KEY CHECK (id = 1), last bigint NOT NULL);
INSERT INTO change_clock VALUES (1, 0);
CREATE TABLE missions (
  name text PRIMARY KEY CHECK (name ~ '^[A-Za-z0-9_-]{1,64}$'),
  created_change bigint NOT NULL);
CREATE TABLE keyframes (
  mission text NOT NULL REFERENCES missions (name) ON DELETE CASCADE,
  seq bigint NOT NULL CHECK (seq BETWEEN 0 AND 2147483647),
  rev bigint NOT NULL CHECK (rev BETWEEN 0 AND 2147483647),
  record text NOT NULL,
  glb bytea NOT NULL,
  change bigint NOT NULL,
  CONSTRAINT keyframes_once UNIQUE (mission, seq, rev),
  CONSTRAINT keyframes_one_per_seq UNIQUE (mission, seq));
CREATE TABLE mission_changes (
  change bigint PRIMARY KEY,
  mission text NOT NULL,
  kind text NOT NULL CHECK (kind IN ('put', 'available', 'remove')),
  seq bigint,
  record text);
CREATE TABLE tile_hierarchies (
  mission text PRIMARY KEY,
  record bytea NOT NULL);
CREATE TABLE tiles (
  mission text NOT NULL,
  file text NOT NULL,
  bytes bytea NOT NULL,
  PRIMARY KEY (mission, file));
)sql",
    // 2: a mission's tiles are its rows: the committed hierarchy's version (a commit must be newer) and the files it
    // keeps (named or retained: never deleted while it is committed); tiles and hierarchies go with their mission.
    R"sql(
ALTER TABLE tile_hierarchies
  ADD COLUMN version bigint NOT NULL DEFAULT 0 CHECK (version >= 0),
  ADD COLUMN keep text[] NOT NULL DEFAULT '{}';
DELETE FROM tiles WHERE mission NOT IN (SELECT name FROM missions);
DELETE FROM tile_hierarchies WHERE mission NOT IN (SELECT name FROM missions);
ALTER TABLE tiles ADD CONSTRAINT tiles_of_a_mission
  FOREIGN KEY (mission) REFERENCES missions (name) ON DELETE CASCADE;
ALTER TABLE tile_hierarchies ADD CONSTRAINT tile_hierarchies_of_a_mission
  FOREIGN KEY (mission) REFERENCES missions (name) ON DELETE CASCADE;
)sql",
};

}  // namespace

int latest_schema_version() { return static_cast<int>(kMigrations.size()); }

Result<int> migrate(PgConnection& conn) {
  // One starter at a time; the others find the work done. The lock is the session's, released below.
  if (auto st = conn.run("SELECT pg_advisory_lock(7303720431)"); !st) return st.error();
  auto unlock = [&conn] { (void)conn.run("SELECT pg_advisory_unlock(7303720431)"); };
  if (auto st = conn.run("CREATE TABLE IF NOT EXISTS rgbdcast_migrations (version integer PRIMARY KEY, "
                         "applied_at timestamptz NOT NULL DEFAULT now())");
      !st) {
    unlock();
    return st.error();
  }
  auto current = conn.exec("SELECT coalesce(max(version), 0) FROM rgbdcast_migrations");
  if (!current) {
    unlock();
    return current.error();
  }
  int version = static_cast<int>(current->integer(0, 0));
  if (version > latest_schema_version()) {
    unlock();
    return make_error(ErrorCode::kInvalidInput, "postgresql: the database's schema is version " +
                                                    std::to_string(version) + ", newer than this program's (" +
                                                    std::to_string(latest_schema_version()) + ")");
  }
  for (; version < latest_schema_version(); ++version) {
    const int next = version + 1;
    Status st = in_transaction(conn, [&](PgConnection& c) -> Status {
      if (auto s = c.run_script(kMigrations[static_cast<size_t>(version)]); !s) return s;
      return c.run("INSERT INTO rgbdcast_migrations (version) VALUES ($1)", {PgParam::integer(next)});
    });
    if (!st) {
      unlock();
      return make_error(st.error().code, "migration " + std::to_string(next) + ": " + st.error().message);
    }
  }
  unlock();
  return version;
}

Result<std::unique_ptr<PgPool>> open_migrated_pool(const std::string& uri, size_t connections) {
  auto pool = PgPool::open(uri, connections);
  if (!pool) return pool.error();
  {
    auto conn = (*pool)->lease();  // given back before the pool is
    if (!conn) return conn.error();
    if (auto v = migrate(**conn); !v) return v.error();
  }
  return pool;
}

}  // namespace rgbdcast::pgstore
