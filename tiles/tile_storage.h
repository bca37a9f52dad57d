#pragma once
// Where one mission's tile hierarchy (tiles/tile_hierarchy.h) keeps its record (the commit marker) and its tile files
// ("<name>.v<version>.glb", immutable: a changed tile is a new name). Two implementations: a folder of this machine
// (the directory store: directory_tile_storage()), and rows of a database shared by replicas (pgstore/). Contract:
// - write_tile() stores a file before any record names it, replacing an uncommitted file of that name (a cut or
//   refused update's); a file the committed record keeps is never replaced (the call changes nothing: that record is
//   at least the writer's version, so the writer's commit will be refused).
// - commit() is the commit point: the record replaces the committed one whole, or nothing changes. It is refused
//   (false, nothing written) when the committed record's version is not lower than the new one (another writer got
//   there first: an older hierarchy never overwrites a newer one), or when a file it names is not stored with the
//   size the record says (another writer's bytes under the same name: refused rather than served). In the same
//   step it deletes `garbage`, except the files the committed record keeps (named or retained).
// - A reader (read_record(), read_tile()) sees the last committed record whole, and every file it names and retains.
// - collect() deletes what no hierarchy will name: the files neither named nor retained by the committed record,
//   except, in a storage shared by writers, files of versions above `committed_version` (another writer's update
//   under way). remove() deletes the record and every file; in a storage shared by replicas, those of a mission that
//   is gone (they go with it): a replica that learns of a removal late never takes the tiles of a mission made again
//   under the same name.
// Thread-safe: read_tile() and local_file() may run while another thread writes.
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "scene/result.h"

namespace rgbdcast::tiles {

struct TileRecordBytes {
  std::uint64_t version = 0;
  std::vector<std::uint8_t> bytes;
};

struct TileCommit {
  std::uint64_t version = 0;                   // > the committed one's
  std::vector<std::uint8_t> record;            // a JSON object whose "version" is `version`
  std::map<std::string, std::uint64_t> named;  // the files the record names (-> bytes): each stored already
  std::set<std::string> retained;              // files kept while this record is committed (the previous version's)
  std::set<std::string> garbage;               // files to delete now
};

class TileStorage {
 public:
  virtual ~TileStorage() = default;
  // The committed record; nullopt when none was committed (or after remove()).
  virtual Result<std::optional<TileRecordBytes>> read_record() = 0;
  // The committed record's version (0 when none), without its bytes: whether another writer committed since.
  virtual Result<std::uint64_t> committed_version() = 0;
  virtual Status write_tile(const std::string& file, const std::vector<std::uint8_t>& bytes) = 0;
  // kNotFound when the file is not stored.
  virtual Result<std::vector<std::uint8_t>> read_tile(const std::string& file) const = 0;
  // A path on this machine holding the file's bytes (copied there first when the storage is remote), for readers
  // that open files; kNotFound when the file is not stored.
  virtual Result<std::string> local_file(const std::string& file) const = 0;
  // true: committed; false: refused (see above), nothing changed.
  virtual Result<bool> commit(const TileCommit& commit) = 0;
  // Deletes files no committed record names (a build dropped before its commit).
  virtual Status delete_tiles(const std::set<std::string>& files) = 0;
  virtual Status collect(const std::set<std::string>& named, std::uint64_t committed_version) = 0;
  virtual Status remove() = 0;
  virtual std::string where() const = 0;  // for messages: the folder, or the database and mission
};

// The directory store: hierarchy.json (the record, written atomically) and the files in `dir`, created when missing.
// One process owns the folder, through one storage per folder: its version check compares with the record on disk
// when first needed, then with its commits, and what the committed record keeps is known from its commits and
// collect().
Result<std::unique_ptr<TileStorage>> directory_tile_storage(const std::string& dir);

// The version in a tile file's name ("3_0_1.v12.glb" -> 12); nullopt for any other name.
std::optional<std::uint64_t> tile_file_version(const std::string& file);

}  // namespace rgbdcast::tiles
