#pragma once
// GET /v1/scenes/{id}/model.glb?flavor=compact|compat|draco: a stored scene in each GLB flavour (gltf/gltf_io.h).
// - No flavor parameter: not handled here; the caller serves the stored file as it always did.
// - compact: the stored file itself when it already uses EXT_meshopt_compression (every GLB rgbdcast writes by
//   default), else converted once.
// - draco: the compact flavour with KHR_draco_mesh_compression geometry (GeometryCodec::kDraco): the stored file
//   itself when it already uses the extension, else converted once and cached like compat.
// - compat: converted once per scene (convert_glb) and cached in memory, keyed by scene id and the stored file's
//   ETag, so a replaced scene is never served stale. Concurrent first requests convert once: the others wait.
// - Each flavour has its own strong ETag (of its bytes); If-None-Match gives 304. X-Flavor-Cache says "miss" on the
//   request that converted, "hit" when it came from the cache, "stored" for the stored file itself. An unknown flavour
//   is 400 with a JSON body naming the flavours; a stored file that no longer converts is 500.
// The cache holds at most max_cached_bytes of converted files (oldest evicted first). Thread-safe.
#include <cstdint>
#include <future>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "gltf/gltf_io.h"
#include "scene/result.h"
#include "service/scene_store.h"

namespace httplib {
struct Request;
struct Response;
}  // namespace httplib

namespace rgbdcast::service {

// The flavours the service serves: the two GLB flavours, and compact with Draco geometry.
enum class ModelFlavor { kCompact, kCompat, kDraco };
const char* to_string(ModelFlavor flavor);  // "compact", "compat", "draco"
// kInvalidArgument naming the three for anything else.
Result<ModelFlavor> parse_model_flavor(std::string_view name);
// The GLB write options of a flavour: the conversion of a stored scene and the encoding of a mission's model.glb
// (service/mission_routes.h) use the same.
GlbWriteOptions flavor_write_options(ModelFlavor flavor);
// The request's ?flavor=: nullopt in *flavor when absent. A bad or repeated one is answered here (400 with a JSON
// body) and false is returned: the caller sends nothing more.
bool read_flavor_param(const httplib::Request& req, httplib::Response& res, std::optional<ModelFlavor>* flavor);
// Sends a model.glb download from shared bytes (not copied): strong ETag, Cache-Control no-cache, If-None-Match ->
// 304, else 200 with Content-Disposition `filename`.
void send_model(const httplib::Request& req, httplib::Response& res,
                std::shared_ptr<const std::vector<std::uint8_t>> bytes, const std::string& etag,
                const std::string& filename);

struct FlavoredModel {
  std::shared_ptr<const std::vector<std::uint8_t>> bytes;
  std::string etag;          // quoted strong ETag of bytes
  bool stored_file = false;  // the stored file itself (compact asked of a compact scene), not a conversion
};

class ModelFlavors {
 public:
  explicit ModelFlavors(size_t max_cached_bytes = size_t(256) << 20) : max_bytes_(max_cached_bytes) {}

  // The scene's GLB in `flavor`, converted at most once while cached. *converted_now (optional) tells whether this
  // call made it.
  Result<FlavoredModel> get(const StoredScene& scene, ModelFlavor flavor, const SceneStore& store,
                            bool* converted_now = nullptr);
  // Answers the request when it has a flavor parameter (returns true); false leaves it to the caller.
  bool serve(const httplib::Request& req, httplib::Response& res, const StoredScene& scene, const SceneStore& store);
  // Drops the cached flavours of a deleted scene.
  void forget(const std::string& id);

  size_t cached_bytes() const;
  size_t conversions() const;  // files converted since start (for tests: "made once")

 private:
  struct Entry {
    std::string source_etag;
    std::shared_future<Result<FlavoredModel>> model;
    size_t bytes = 0;  // 0 while converting
  };
  using Key = std::pair<std::string, ModelFlavor>;
  void evict_locked();

  const size_t max_bytes_;
  mutable std::mutex mutex_;
  std::map<Key, Entry> entries_;
  std::list<Key> order_;  // oldest first
  size_t total_bytes_ = 0, conversions_ = 0;
};

}  // namespace rgbdcast::service
