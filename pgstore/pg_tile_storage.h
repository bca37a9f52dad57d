#pragma once
// Missions' tiles as rows of PostgreSQL (pgstore/pg_schema.h: tiles, one row per file, the GLB as bytea;
// tile_hierarchies, one row per mission: the committed record, its version and the files it keeps), so that a
// replica that takes a mission over (failover, a restart on another machine, a new replica) loads its tileset
// instead of building it again, and tiles outlive a replica's disk. TileStorage's contract (tiles/tile_storage.h);
// besides it:
// - write_tile() is one upsert whose update applies only to a row the committed record does not keep, so a kept
//   tile is never rewritten and an uncommitted one (a crashed or refused replica's) never blocks a writer.
// - commit() is one transaction under the mission's row lock (every write but write_tile() takes it, so commits,
//   deletions and collections of one mission are serialized across replicas): it is refused unless the stored
//   version is lower and every named file is stored with the size the record says; it replaces the record, version
//   and kept files, and deletes the garbage. Nothing a committed record keeps is ever deleted or rewritten.
// - Two replicas whose uncommitted builds share a name and a size, one rewriting the other's between its write and
//   its commit, are not told apart (sizes are compared, not contents); builds are functions of their inputs, so
//   such a pair is almost always the same bytes.
// - collect() deletes the mission's files that the committed record does not keep and whose version is not above
//   it (a file of a higher version is another replica's update under way).
// - remove() leaves the rows of a mission that exists (made again since it was removed): a mission's rows go with
//   it (ON DELETE CASCADE), remove() only drops this machine's copy and what a replica wrote after the removal.
// - The files are also kept in a folder of this machine (a cache: read there first, fetched from the database when
//   missing, written through), which local_file() names.
#include <memory>
#include <string>

#include "pgstore/pg_connection.h"
#include "tiles/tile_storage.h"

namespace rgbdcast::pgstore {

class PgTileStores {
 public:
  // Connects (pool of `connections`), applies the schema's migrations.
  static Result<std::unique_ptr<PgTileStores>> open(const std::string& uri, size_t connections = 4);
  // Mission `mission`'s tiles, cached in `cache_dir` (created when missing).
  Result<std::unique_ptr<tiles::TileStorage>> storage(const std::string& mission, const std::string& cache_dir) const;

 private:
  explicit PgTileStores(std::shared_ptr<PgPool> pool) : pool_(std::move(pool)) {}
  std::shared_ptr<PgPool> pool_;
};

}  // namespace rgbdcast::pgstore
