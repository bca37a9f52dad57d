#pragma once
// Opens the service's stores from its options: the directory store in data_dir (the embedded default), or the
// PostgreSQL stores (pgstore/) when the store option is a libpq URI. The only place that knows both.
#include <functional>
#include <memory>
#include <string>

#include "scene/result.h"
#include "service/mission_store.h"
#include "service/mission_tiles.h"
#include "service/scene_store.h"

namespace rgbdcast::service {

struct OpenedStores {
  std::unique_ptr<SceneStore> scenes;
  std::unique_ptr<MissionStore> missions;
  std::string kind;  // "directory" or "postgresql"
  // Sets (or, with an empty function, clears) what runs after each mission change made through another replica;
  // clearing waits for a call under way. A no-op for the directory store, whose changes are all this process's.
  std::function<void(std::function<void(const std::string&)>)> follow_changes;
  // Where missions' tiles are kept: empty for the directory store (--data-dir), the database's rows for PostgreSQL.
  TileStorageFactory tile_storage;
};

// `store`: empty or "directory" (data_dir), or postgresql://... / postgres://... Errors: kInvalidArgument for any
// other text, the store's own errors otherwise (kUnavailable: the database cannot be reached).
Result<OpenedStores> open_stores(const std::string& store, const std::string& data_dir);

}  // namespace rgbdcast::service
