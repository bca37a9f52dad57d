#pragma once
// Scenes as rows of PostgreSQL (pgstore/pg_schema.h: table scenes, the GLB as bytea), shared by every replica that
// opens the same database. SceneStore's contract (service/scene_store.h); besides it:
// - put() is one INSERT: a whole scene or none; every read asks the database, so a scene stored or removed through
//   one replica is seen by all at once.
// - A database that cannot be reached makes reads "not found" / empty and writes kUnavailable (HTTP 503); ping()
//   says so for /readyz.
#include <memory>
#include <string>

#include "pgstore/pg_connection.h"
#include "service/scene_store.h"

namespace rgbdcast::pgstore {

class PgSceneStore final : public service::SceneStore {
 public:
  // Connects (pool of `connections`), applies the schema's migrations.
  static Result<std::unique_ptr<PgSceneStore>> open(const std::string& uri, size_t connections = 8);

  Result<service::StoredScene> put(const std::vector<std::uint8_t>& glb, nlohmann::json metadata) override;
  std::optional<service::StoredScene> get(const std::string& id) const override;
  std::vector<service::StoredScene> list() const override;
  void for_each(const std::function<void(const service::StoredScene&)>& f) const override;
  Status remove(const std::string& id) override;
  Result<std::vector<std::uint8_t>> read_glb(const std::string& id) const override;
  size_t count() const override;
  std::uint64_t total_bytes() const override;
  Status ping() const override;

 private:
  explicit PgSceneStore(std::unique_ptr<PgPool> pool) : pool_(std::move(pool)) {}
  std::unique_ptr<PgPool> pool_;
};

}  // namespace rgbdcast::pgstore
