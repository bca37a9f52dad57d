#pragma once
// The PostgreSQL schema, as numbered migrations applied in order at start (migrate()). Contract:
// - Each migration runs once, in its own transaction with its row in rgbdcast_migrations, under an advisory lock, so
//   replicas starting together apply it once; a database newer than this program (a version it does not know) is
//   refused with kInvalidInput, never written to.
// - Tables: scenes (metadata in columns, the GLB as bytea); missions; keyframes, one row per (mission, seq, rev),
//   unique on it (the idempotency key) and on (mission, seq) (one revision per seq); change_clock, a one-row counter
//   that every mission write increments first (so writes of missions are serialized and their change numbers commit
//   in order); mission_changes, the log replicas catch up from; tiles (one row per tile file) and tile_hierarchies
//   (one row per mission: the committed record, its version and the files it keeps), deleted with their mission
//   (pgstore/pg_tile_storage.h).
#include <memory>
#include <string>

#include "pgstore/pg_connection.h"

namespace rgbdcast::pgstore {

inline constexpr const char* kMissionChannel = "rgbdcast_missions";  // NOTIFY channel: payload "<change>"

// Applies what is missing; returns the schema version now in place.
Result<int> migrate(PgConnection& conn);
// A pool of `connections` on `uri` (PgPool::open) whose database has every migration applied: what each store opens.
Result<std::unique_ptr<PgPool>> open_migrated_pool(const std::string& uri, size_t connections);
int latest_schema_version();

}  // namespace rgbdcast::pgstore
