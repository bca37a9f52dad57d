#include "service/store_open.h"

#include "pgstore/pg_connection.h"
#include "pgstore/pg_mission_store.h"
#include "pgstore/pg_scene_store.h"
#include "pgstore/pg_tile_storage.h"

namespace rgbdcast::service {

Result<OpenedStores> open_stores(const std::string& store, const std::string& data_dir) {
  OpenedStores out;
  if (store.empty() || store == "directory") {
    auto scenes = SceneStore::open(data_dir);
    if (!scenes) return scenes.error();
    auto missions = MissionStore::open(data_dir);
    if (!missions) return missions.error();
    out.scenes = std::move(*scenes);
    out.missions = std::move(*missions);
    out.kind = "directory";
    out.follow_changes = [](std::function<void(const std::string&)>) {};
    return out;
  }
  if (!pgstore::is_postgres_uri(store))
    return make_error(ErrorCode::kInvalidArgument,
                      "--store must be \"directory\" or a PostgreSQL URI (postgresql://...)");
  auto scenes = pgstore::PgSceneStore::open(store);
  if (!scenes) return scenes.error();
  auto missions = pgstore::PgMissionStore::open(store);
  if (!missions) return missions.error();
  auto tiles = pgstore::PgTileStores::open(store);
  if (!tiles) return tiles.error();
  pgstore::PgMissionStore* pg = missions->get();
  out.scenes = std::move(*scenes);
  out.missions = std::move(*missions);
  out.kind = "postgresql";
  out.follow_changes = [pg](std::function<void(const std::string&)> f) { pg->set_on_change(std::move(f)); };
  out.tile_storage = [stores = std::shared_ptr<pgstore::PgTileStores>(std::move(*tiles))](
                         const std::string& mission, const std::string& dir) { return stores->storage(mission, dir); };
  return out;
}

}  // namespace rgbdcast::service
