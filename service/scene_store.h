#pragma once
// Stored scenes: the SceneStore interface and its embedded default, the directory store. Ids are 32 lowercase hex
// digits from std::random_device.
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "scene/result.h"

namespace rgbdcast::service {

bool is_valid_scene_id(std::string_view id);
std::string new_scene_id();

// One stored scene as the server holds it in memory. The metadata is kept as its compact JSON text and parsed on
// demand (GET of one scene, the POST answer): an nlohmann::json tree of the soak's 1,497-byte metadata took 6.4 kB
// of heap, and every stored scene holds one for the server's lifetime. The listing's fields are copied out once.
struct StoredScene {
  std::string id;
  std::uint64_t bytes = 0;  // size of the GLB
  std::string etag;         // quoted strong ETag of the GLB bytes
  double created_unix_s = 0.0;
  // The listing's fields of the metadata, when present with these types (a hand-edited file may lack them).
  std::optional<std::uint64_t> points, triangles, vertices;
  std::optional<std::string> source;
  // What put() was given (stats), plus id, bytes, etag, created_unix_s: one JSON object, compact (no spaces).
  std::string metadata_json;
  nlohmann::json metadata() const;  // metadata_json parsed (checked when stored, so always an object)
};

// Where scenes live: the interface every store implements (the directory below, PostgreSQL in pgstore/), tested by
// one contract suite (tests/service/test_store_contract.cpp). Contract of every implementation:
// - put() stores a whole scene or nothing, with a new id (new_scene_id); the returned StoredScene carries id, bytes,
//   etag (etag_of) and created_unix_s, which are also written into its metadata.
// - get(), read_glb() of an id that is not a valid scene id are "not found", never an error of the backend.
// - list() and for_each() are oldest first; remove() of an unknown id is kNotFound.
// - Thread-safe: every method may be called from any thread.
class SceneStore {
 public:
  virtual ~SceneStore() = default;
  // The embedded default: the directory store in <data_dir>/scenes (DirectorySceneStore).
  static Result<std::unique_ptr<SceneStore>> open(const std::string& data_dir);

  // Stores a GLB (already validated by the caller) with its metadata object; returns the new scene.
  virtual Result<StoredScene> put(const std::vector<std::uint8_t>& glb, nlohmann::json metadata) = 0;
  virtual std::optional<StoredScene> get(const std::string& id) const = 0;
  virtual std::vector<StoredScene> list() const = 0;  // oldest first
  // Calls f on every scene, oldest first (f must not call the store): the listing route's way.
  virtual void for_each(const std::function<void(const StoredScene&)>& f) const = 0;
  virtual Status remove(const std::string& id) = 0;  // kNotFound when unknown
  virtual Result<std::vector<std::uint8_t>> read_glb(const std::string& id) const = 0;

  virtual size_t count() const = 0;
  virtual std::uint64_t total_bytes() const = 0;
  // What opening the store removed (what a crash left) and set aside (damaged records), one line each.
  virtual const std::vector<std::string>& cleaned_on_open() const { return none_; }
  virtual const std::vector<std::string>& quarantined() const { return none_; }
  // Whether the store answers now (a database may be unreachable for a while): /readyz.
  virtual Status ping() const { return ok_status(); }

 private:
  std::vector<std::string> none_;
};

// Scenes on disk: <data_dir>/scenes/<id>.glb and <id>.json (metadata). Besides SceneStore's contract:
// - put() writes the GLB, then the metadata, each to a temporary name, fsync, rename, fsync of the folder; the
//   metadata file is the commit marker, so a crash at any point leaves either a whole scene or none.
// - open() lists the committed scenes again and deletes what an interrupted put() or remove() left (temporary files,
//   a GLB without metadata). A metadata file that does not parse, or whose id, bytes, etag or created_unix_s has
//   the wrong type, is moved with its GLB to <data_dir>/quarantine/ (one line each in quarantined()), and the rest
//   is served: one bad file never stops the server.
// - Ids are 32 lowercase hex digits; anything else is rejected before it reaches a path, so an id can never name a
//   file outside the scenes folder.
// - for_each() runs f under the store's lock, without copying every scene's metadata per request (no measurable RSS
//   effect in bench/soak.sh).
class DirectorySceneStore final : public SceneStore {
 public:
  // Creates <data_dir>/scenes when missing, cleans what a crash left, loads the metadata of every scene.
  static Result<std::unique_ptr<DirectorySceneStore>> open(const std::string& data_dir);

  Result<StoredScene> put(const std::vector<std::uint8_t>& glb, nlohmann::json metadata) override;
  std::optional<StoredScene> get(const std::string& id) const override;
  std::vector<StoredScene> list() const override;
  void for_each(const std::function<void(const StoredScene&)>& f) const override;
  Status remove(const std::string& id) override;
  Result<std::vector<std::uint8_t>> read_glb(const std::string& id) const override;
  std::string glb_path(const std::string& id) const;  // only for a valid id

  size_t count() const override;
  std::uint64_t total_bytes() const override;
  // Files open() removed: temporary files and orphan GLBs (for the log and the tests).
  const std::vector<std::string>& cleaned_on_open() const override { return cleaned_; }
  // One line per scene open() moved to quarantine/: "<id>: <reason> (moved to quarantine/)".
  const std::vector<std::string>& quarantined() const override { return quarantined_; }

 private:
  explicit DirectorySceneStore(std::string scenes_dir) : dir_(std::move(scenes_dir)) {}
  std::string dir_;
  mutable std::mutex mutex_;
  std::map<std::string, StoredScene> scenes_;
  std::vector<std::string> cleaned_;
  std::vector<std::string> quarantined_;
};

// A new scene's bookkeeping, as every store fills it: a new id, bytes, etag, created_unix_s (now), written into the
// metadata object too (made an object when it is not), and the listing's fields kept.
StoredScene new_stored_scene(const std::vector<std::uint8_t>& glb, nlohmann::json& metadata);
// A stored metadata text read back: the scene it describes, or kInvalidInput with the reason.
Result<StoredScene> parse_scene_metadata(const std::string& id, const std::string& text);

// For the mission store too (service/mission_store.h), so that one set of file helpers serves both:
// a whole small file; <stem>.json and <stem>.glb of from_dir moved (when there) to
// <data_dir>/quarantine/<prefix><stem>.json|.glb. Files are written with base/atomic_file.h.
Result<std::string> read_text(const std::string& path);
Status quarantine(const std::string& data_dir, const std::string& from_dir, const std::string& stem,
                  const std::string& prefix);

// A strong ETag for bytes: "\"<16 hex digits of FNV-1a 64>-<size>\"".
std::string etag_of(const std::uint8_t* data, size_t size);

}  // namespace rgbdcast::service
