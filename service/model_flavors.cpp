#include "service/model_flavors.h"

#include <httplib.h>

#include <algorithm>
#include <optional>

#include <nlohmann/json.hpp>

#include "gltf/glb_container.h"
#include "service/http_reply.h"

namespace rgbdcast::service {
namespace {

bool uses_extension(const std::vector<std::uint8_t>& glb, const char* name) {
  auto chunks = glb::parse_glb(glb.data(), glb.size());
  if (!chunks) return false;
  const auto doc = nlohmann::json::parse(chunks->json, nullptr, false);
  if (doc.is_discarded() || !doc.contains("extensionsUsed") || !doc["extensionsUsed"].is_array()) return false;
  for (const auto& e : doc["extensionsUsed"])
    if (e == name) return true;
  return false;
}

// The stored file in `flavor`: itself when it already is in it, else converted.
Result<FlavoredModel> make_flavor(const StoredScene& scene, ModelFlavor flavor, const SceneStore& store,
                                  bool* converted) {
  auto stored = store.read_glb(scene.id);
  if (!stored) return stored.error();
  *converted = false;
  if ((flavor == ModelFlavor::kCompact && uses_extension(*stored, "EXT_meshopt_compression")) ||
      (flavor == ModelFlavor::kDraco && uses_extension(*stored, "KHR_draco_mesh_compression")))
    return FlavoredModel{std::make_shared<const std::vector<std::uint8_t>>(std::move(*stored)), scene.etag, true};
  auto out = convert_glb(stored->data(), stored->size(), flavor_write_options(flavor));
  if (!out)
    return make_error(ErrorCode::kInternal, "stored scene " + scene.id + " does not convert to " + to_string(flavor) +
                                                ": " + out.error().message);
  *converted = true;
  std::string etag = etag_of(out->data(), out->size());
  return FlavoredModel{std::make_shared<const std::vector<std::uint8_t>>(std::move(*out)), std::move(etag)};
}

}  // namespace

const char* to_string(ModelFlavor flavor) {
  switch (flavor) {
    case ModelFlavor::kCompat:
      return "compat";
    case ModelFlavor::kDraco:
      return "draco";
    default:
      return "compact";
  }
}

Result<ModelFlavor> parse_model_flavor(std::string_view name) {
  if (name == "compact") return ModelFlavor::kCompact;
  if (name == "compat") return ModelFlavor::kCompat;
  if (name == "draco") return ModelFlavor::kDraco;
  return make_error(ErrorCode::kInvalidArgument,
                    "unknown GLB flavor '" + std::string(name) +
                        "' (compact: meshopt + quantized, for three.js, "
                        "Babylon.js, Foxglove; draco: KHR_draco_mesh_compression, for three.js with DRACOLoader; "
                        "compat: plain floats, for Blender, Assimp and every viewer)");
}

GlbWriteOptions flavor_write_options(ModelFlavor flavor) {
  GlbWriteOptions options;
  options.flavor = flavor == ModelFlavor::kCompat ? GlbFlavor::kCompat : GlbFlavor::kCompact;
  options.geometry_codec = flavor == ModelFlavor::kDraco ? GeometryCodec::kDraco : GeometryCodec::kMeshopt;
  return options;
}

bool read_flavor_param(const httplib::Request& req, httplib::Response& res, std::optional<ModelFlavor>* flavor) {
  *flavor = std::nullopt;
  if (!req.has_param("flavor")) return true;
  if (req.get_param_value_count("flavor") != 1) {
    send_error(res, 400, "flavor given more than once");
    return false;
  }
  auto parsed = parse_model_flavor(req.get_param_value("flavor"));
  if (!parsed) {
    send_error(res, 400, parsed.error().message);
    return false;
  }
  *flavor = *parsed;
  return true;
}

void send_model(const httplib::Request& req, httplib::Response& res,
                std::shared_ptr<const std::vector<std::uint8_t>> bytes, const std::string& etag,
                const std::string& filename) {
  res.set_header("Cache-Control", "no-cache");
  if (answer_not_modified(req, res, etag)) return;
  res.status = 200;
  res.set_header("Content-Disposition", "attachment; filename=\"" + filename + "\"");
  const size_t size = bytes->size();
  res.set_content_provider(size, "model/gltf-binary",
                           [bytes = std::move(bytes)](size_t offset, size_t length, httplib::DataSink& sink) {
                             if (offset >= bytes->size()) return false;
                             length = std::min(length, bytes->size() - offset);
                             return sink.write(reinterpret_cast<const char*>(bytes->data()) + offset, length);
                           });
}

Result<FlavoredModel> ModelFlavors::get(const StoredScene& scene, ModelFlavor flavor, const SceneStore& store,
                                        bool* converted_now) {
  if (converted_now) *converted_now = false;
  const Key key{scene.id, flavor};
  std::promise<Result<FlavoredModel>> promise;
  std::optional<std::shared_future<Result<FlavoredModel>>> cached;
  {
    std::lock_guard lock(mutex_);
    auto it = entries_.find(key);
    if (it != entries_.end() && it->second.source_etag == scene.etag) {
      cached = it->second.model;
      order_.remove(key);
      order_.push_back(key);
    } else if (it != entries_.end()) {  // the scene was replaced: its old flavours are stale
      total_bytes_ -= it->second.bytes;
      order_.remove(key);
      entries_.erase(it);
    }
    if (!cached) {
      entries_[key] = Entry{scene.etag, promise.get_future().share(), 0};
      order_.push_back(key);
    }
  }
  if (cached) return cached->get();  // waits, without the lock, for a conversion in flight
  bool converted = false;
  Result<FlavoredModel> made = make_error(ErrorCode::kInternal, "conversion failed");
  try {
    made = make_flavor(scene, flavor, store, &converted);
  } catch (const std::exception& e) {  // e.g. out of memory: an error for every waiter, never a broken promise
    made = make_error(ErrorCode::kInternal, std::string("conversion failed: ") + e.what());
  }
  {
    std::lock_guard lock(mutex_);
    conversions_ += converted ? 1 : 0;
    if (converted_now) *converted_now = converted;
    auto it = entries_.find(key);
    const bool still_ours = it != entries_.end() && it->second.source_etag == scene.etag && it->second.bytes == 0;
    if (still_ours && made && converted) {
      it->second.bytes = made->bytes->size();
      total_bytes_ += it->second.bytes;
      evict_locked();
    } else if (still_ours) {  // errors are retried by the next request; the stored compact file is not copied
      order_.remove(key);
      entries_.erase(it);
    }
  }
  promise.set_value(made);
  return made;
}

void ModelFlavors::evict_locked() {
  // Oldest first, never the newest entry, never a conversion in flight (bytes == 0).
  for (auto it = order_.begin(); total_bytes_ > max_bytes_ && it != order_.end() && std::next(it) != order_.end();) {
    auto e = entries_.find(*it);
    if (e == entries_.end() || e->second.bytes == 0) {
      ++it;
      continue;
    }
    total_bytes_ -= e->second.bytes;
    entries_.erase(e);
    it = order_.erase(it);
  }
}

void ModelFlavors::forget(const std::string& id) {
  std::lock_guard lock(mutex_);
  for (auto it = entries_.begin(); it != entries_.end();) {
    if (it->first.first != id) {
      ++it;
      continue;
    }
    total_bytes_ -= it->second.bytes;
    order_.remove(it->first);
    it = entries_.erase(it);
  }
}

size_t ModelFlavors::cached_bytes() const {
  std::lock_guard lock(mutex_);
  return total_bytes_;
}

size_t ModelFlavors::conversions() const {
  std::lock_guard lock(mutex_);
  return conversions_;
}

bool ModelFlavors::serve(const httplib::Request& req, httplib::Response& res, const StoredScene& scene,
                         const SceneStore& store) {
  if (!req.has_param("flavor")) return false;
  std::optional<ModelFlavor> flavor;
  if (!read_flavor_param(req, res, &flavor)) return true;
  bool converted_now = false;
  auto model = get(scene, *flavor, store, &converted_now);
  if (!model) {
    send_error(res, http_status_for(model.error().code), model.error().message);
    return true;
  }
  res.set_header("X-Flavor-Cache", model->stored_file ? "stored" : converted_now ? "miss" : "hit");
  send_model(req, res, model->bytes, model->etag, scene.id + "-" + to_string(*flavor) + ".glb");
  return true;
}

}  // namespace rgbdcast::service
