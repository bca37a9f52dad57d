#include "pgstore/pg_scene_store.h"

#include "pgstore/pg_schema.h"

namespace rgbdcast::pgstore {

using service::StoredScene;

Result<std::unique_ptr<PgSceneStore>> PgSceneStore::open(const std::string& uri, size_t connections) {
  auto pool = open_migrated_pool(uri, connections);
  if (!pool) return pool.error();
  return std::unique_ptr<PgSceneStore>(new PgSceneStore(std::move(*pool)));
}

Result<StoredScene> PgSceneStore::put(const std::vector<std::uint8_t>& glb, nlohmann::json metadata) {
  StoredScene s = service::new_stored_scene(glb, metadata);
  auto conn = pool_->lease();
  if (!conn) return conn.error();
  auto st = (*conn)->run(
      "INSERT INTO scenes (id, created_unix_s, bytes, etag, metadata, glb) VALUES ($1, $2, $3, $4, $5, $6)",
      {PgParam::text(s.id), PgParam::real(s.created_unix_s), PgParam::integer(static_cast<std::int64_t>(s.bytes)),
       PgParam::text(s.etag), PgParam::text(s.metadata_json), PgParam::bytes(glb.data(), glb.size())});
  if (!st) return st.error();
  return s;
}

std::optional<StoredScene> PgSceneStore::get(const std::string& id) const {
  if (!service::is_valid_scene_id(id)) return std::nullopt;
  auto conn = pool_->lease();
  if (!conn) return std::nullopt;
  auto r = (*conn)->exec("SELECT metadata FROM scenes WHERE id = $1", {PgParam::text(id)});
  if (!r || r->rows() == 0) return std::nullopt;
  auto s = service::parse_scene_metadata(id, r->text(0, 0));
  if (!s) return std::nullopt;
  return *s;
}

void PgSceneStore::for_each(const std::function<void(const StoredScene&)>& f) const {
  auto conn = pool_->lease();
  if (!conn) return;
  auto r = (*conn)->exec("SELECT id, metadata FROM scenes ORDER BY created_unix_s, id");
  if (!r) return;
  for (int i = 0; i < r->rows(); ++i)
    if (auto s = service::parse_scene_metadata(r->text(i, 0), r->text(i, 1))) f(*s);
}

std::vector<StoredScene> PgSceneStore::list() const {
  std::vector<StoredScene> out;
  for_each([&out](const StoredScene& s) { out.push_back(s); });
  return out;
}

Status PgSceneStore::remove(const std::string& id) {
  if (!service::is_valid_scene_id(id)) return make_error(ErrorCode::kNotFound, "no scene " + id);
  auto conn = pool_->lease();
  if (!conn) return conn.error();
  auto r = (*conn)->exec("DELETE FROM scenes WHERE id = $1", {PgParam::text(id)});
  if (!r) return r.error();
  if (r->affected() == 0) return make_error(ErrorCode::kNotFound, "no scene " + id);
  return ok_status();
}

Result<std::vector<std::uint8_t>> PgSceneStore::read_glb(const std::string& id) const {
  if (!service::is_valid_scene_id(id)) return make_error(ErrorCode::kNotFound, "no scene " + id);
  auto conn = pool_->lease();
  if (!conn) return conn.error();
  auto r = (*conn)->exec("SELECT glb FROM scenes WHERE id = $1", {PgParam::text(id)}, /*binary_result=*/true);
  if (!r) return r.error();
  if (r->rows() == 0) return make_error(ErrorCode::kNotFound, "no scene " + id);
  return r->bytes(0, 0);
}

size_t PgSceneStore::count() const {
  auto conn = pool_->lease();
  if (!conn) return 0;
  auto r = (*conn)->exec("SELECT count(*) FROM scenes");
  return r ? static_cast<size_t>(r->integer(0, 0)) : 0;
}

std::uint64_t PgSceneStore::total_bytes() const {
  auto conn = pool_->lease();
  if (!conn) return 0;
  auto r = (*conn)->exec("SELECT coalesce(sum(bytes), 0) FROM scenes");
  return r ? static_cast<std::uint64_t>(r->integer(0, 0)) : 0;
}

Status PgSceneStore::ping() const { return pool_->ping(); }

}  // namespace rgbdcast::pgstore
