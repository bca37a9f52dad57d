#include "tiles/tile_hierarchy.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <list>
#include <memory>

#include <nlohmann/json.hpp>

#include "gltf/atomic_file.h"
#include "gltf/gltf_io.h"
#include "scene/render_bytes.h"
#include "tiles/tileset_json.h"

namespace rgbdcast::tiles {
namespace fs = std::filesystem;
namespace {

constexpr const char* kManifest = "hierarchy.json";
constexpr int kFormat = 4;  // 2: inner tiles are textured; 3: their texels at least twice their children's;
                            // 4: records carry render bytes
constexpr size_t kMaxManifestBytes = size_t(256) << 20;

nlohmann::json options_json(const TilingOptions& o) {
  return {{"leaf_size_m", o.leaf_size_m},     {"top_level", o.top_level},
          {"inner_triangles", o.inner_triangles}, {"leaf_max_atlas_side_px", o.leaf.max_atlas_side_px},
          {"leaf_gutter_px", o.leaf.gutter_px}, {"leaf_jpeg_quality", o.leaf.jpeg_quality},
          {"inner_max_atlas_side_px", o.inner.atlas.max_atlas_side_px}, {"inner_gutter_px", o.inner.atlas.gutter_px},
          {"inner_jpeg_quality", o.inner.atlas.jpeg_quality}, {"inner_texels_per_error", o.inner.texels_per_error}};
}

// The quantization step of a tile's positions bounds how far its stored vertices are from the exact ones: the box
// is grown by it so that it holds the GLB's (dequantized) positions. encode_glb's step is 1 mm, or extent / 65,535.
double position_pad_m(const Eigen::AlignedBox3d& box) {
  return box.isEmpty() ? 0.001 : std::max(0.001, (box.max() - box.min()).maxCoeff() / 32767.0);
}

}  // namespace

// The placed keyframes one update reads, the most recent few kept decoded. A scene is shared: a caller that holds
// many at once (a leaf seen by more keyframes than the cache keeps) keeps each alive after the cache drops it.
class TileHierarchy::SceneCache {
 public:
  SceneCache(const KeyframeLoader& load, size_t keep) : load_(load), keep_(keep) {}
  Result<std::shared_ptr<const Scene>> get(const KeyframeId& id) {
    for (auto it = entries_.begin(); it != entries_.end(); ++it)
      if (it->first == id) {
        entries_.splice(entries_.begin(), entries_, it);
        return entries_.front().second;
      }
    auto scene = load_(id);
    if (!scene)
      return make_error(scene.error().code, "keyframe " + std::to_string(id.seq) + " rev " + std::to_string(id.rev) +
                                                ": " + scene.error().message);
    entries_.emplace_front(id, std::make_shared<const Scene>(std::move(*scene)));
    if (entries_.size() > keep_) entries_.pop_back();
    return entries_.front().second;
  }

 private:
  const KeyframeLoader& load_;
  size_t keep_;
  std::list<std::pair<KeyframeId, std::shared_ptr<const Scene>>> entries_;  // most recent first
};

std::string TileRecord::file() const { return key.name() + ".v" + std::to_string(version) + ".glb"; }

// One update in the making: the new state, built beside the committed one.
struct TileHierarchy::Build {
  std::uint64_t version = 0;
  std::map<TileKey, TileRecord> tiles;
  std::map<std::int64_t, KeyframeEntry> keyframes;
  std::set<TileKey> dirty;  // tiles to build again (leaves first, then each level's parents)
  UpdateStats stats;
};

Result<std::unique_ptr<TileHierarchy>> TileHierarchy::open(const std::string& dir, const TilingOptions& options) {
  if (!(options.leaf_size_m > 0.0) || options.top_level < 1 || options.top_level > 30 || options.inner_triangles == 0)
    return make_error(ErrorCode::kInvalidArgument, "tiles: leaf_size_m > 0, top_level 1..30, inner_triangles > 0");
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return make_error(ErrorCode::kIo, "tiles: cannot create " + dir + ": " + ec.message());
  std::unique_ptr<TileHierarchy> h(new TileHierarchy(dir, options));
  if (!h->load_committed()) {  // unreadable or made with other options: start again
    h->tiles_.clear();
    h->keyframes_.clear();
    h->version_ = 0;
  }
  // Whatever the committed records do not name is a cut update's (or an older version's): delete it.
  std::set<std::string> named = {kManifest};
  for (const auto& [key, r] : h->tiles_) named.insert(r.file());
  for (const auto& entry : fs::directory_iterator(dir, ec))
    if (!named.count(entry.path().filename().string())) fs::remove_all(entry.path(), ec);
  h->publish();
  return h;
}

TileHierarchy::~TileHierarchy() = default;

Status TileHierarchy::load_committed() {
  const std::string path = dir_ + "/" + kManifest;
  if (!fs::exists(path)) return ok_status();
  auto bytes = glb::read_file_bytes(path, kMaxManifestBytes);
  if (!bytes) return bytes.error();
  const auto j = nlohmann::json::parse(bytes->begin(), bytes->end(), nullptr, false);
  if (j.is_discarded() || !j.is_object() || j.value("format", 0) != kFormat ||
      j.value("options", nlohmann::json()) != options_json(options_))
    return make_error(ErrorCode::kInvalidInput, "tiles: " + path + " is not this hierarchy's");
  try {
    version_ = j.at("version").get<std::uint64_t>();
    for (const auto& k : j.at("keyframes")) {
      KeyframeEntry e;
      e.rev = k.at(1).get<std::int64_t>();
      for (const auto& name : k.at(2)) {
        auto key = parse_tile_key(name.get<std::string>());
        if (!key) return make_error(ErrorCode::kInvalidInput, "tiles: bad tile name in " + path);
        e.leaves.push_back(*key);
      }
      keyframes_[k.at(0).get<std::int64_t>()] = std::move(e);
    }
    for (const auto& t : j.at("tiles")) {
      auto key = parse_tile_key(t.at(0).get<std::string>());
      if (!key) return make_error(ErrorCode::kInvalidInput, "tiles: bad tile name in " + path);
      TileRecord r;
      r.key = *key;
      r.version = t.at(1).get<std::uint64_t>();
      r.box = Eigen::AlignedBox3d(Eigen::Vector3d(t.at(2), t.at(3), t.at(4)), Eigen::Vector3d(t.at(5), t.at(6), t.at(7)));
      r.geometric_error_m = t.at(8).get<double>();
      r.triangles = t.at(9).get<std::uint64_t>();
      r.bytes = t.at(10).get<std::uint64_t>();
      r.render_bytes = t.at(11).get<std::uint64_t>();
      tiles_[r.key] = r;
    }
  } catch (const nlohmann::json::exception&) {
    return make_error(ErrorCode::kInvalidInput, "tiles: " + path + " has a field of the wrong type");
  }
  return ok_status();
}

Result<UpdateStats> TileHierarchy::update(const std::vector<KeyframeId>& wanted, const KeyframeLoader& load) {
  Build b;
  b.version = version_ + 1;
  b.tiles = tiles_;
  b.keyframes = keyframes_;
  std::map<std::int64_t, std::int64_t> want;
  for (const auto& k : wanted) want[k.seq] = k.rev;
  // Keyframes gone or replaced: the leaves they touched are built again without them.
  for (auto it = b.keyframes.begin(); it != b.keyframes.end();) {
    auto w = want.find(it->first);
    if (w != want.end() && w->second == it->second.rev) {
      ++it;
      continue;
    }
    b.dirty.insert(it->second.leaves.begin(), it->second.leaves.end());
    ++b.stats.keyframes_changed;
    it = b.keyframes.erase(it);
  }
  SceneCache scenes(load, 16);
  for (const auto& [seq, rev] : want) {
    if (b.keyframes.count(seq)) continue;
    auto scene = scenes.get({seq, rev});
    if (!scene) return scene.error();
    KeyframeEntry e{rev, leaves_touched(**scene, options_.leaf_size_m)};
    b.dirty.insert(e.leaves.begin(), e.leaves.end());
    if (!keyframes_.count(seq)) ++b.stats.keyframes_changed;
    b.keyframes[seq] = std::move(e);
  }
  b.stats.version = version_;
  if (b.dirty.empty() && b.stats.keyframes_changed == 0) return b.stats;
  if (auto st = build_leaves(b, scenes); !st) return st.error();
  if (auto st = build_inner_levels(b); !st) return st.error();
  if (auto st = commit(b); !st) return st.error();
  b.stats.version = version_;
  return b.stats;
}

namespace {

// Encodes a tile's mesh as its GLB (compact: quantized, meshopt-compressed; its texture as the mesh holds it) and
// writes it; the record gets its size and triangle count, and its box grows to hold the GLB's positions.
Status write_tile(const std::string& dir, Mesh mesh, TileRecord* r) {
  Scene scene;
  SceneNode node;
  node.name = "tile_" + r->key.name();
  node.mesh = std::move(mesh);
  scene.nodes.push_back(std::move(node));
  auto glb = encode_glb(scene);
  if (!glb) return make_error(glb.error().code, "tile " + r->key.name() + ": " + glb.error().message);
  if (auto st = glb::write_file_atomically(dir + "/" + r->file(), *glb); !st) return st.error();
  r->bytes = glb->size();
  r->triangles = scene.triangle_count();
  r->render_bytes = render_bytes(scene);
  const Eigen::AlignedBox3d box = mesh_box(scene.nodes.front().mesh, 0.0);
  r->box.extend(mesh_box(scene.nodes.front().mesh, position_pad_m(box)));
  return ok_status();
}

// A tile's content as its parent reads it: the stored GLB decoded, whether it was written in this update or an
// earlier one, so that a parent's input does not depend on which.
Result<Mesh> read_tile(const std::string& dir, const TileRecord& r) {
  auto bytes = glb::read_file_bytes(dir + "/" + r.file(), size_t(512) << 20);
  if (!bytes) return bytes.error();
  auto scene = decode_glb(bytes->data(), bytes->size());
  if (!scene || scene->nodes.empty())
    return make_error(ErrorCode::kInvalidInput, "tile " + r.key.name() + ": stored GLB does not decode");
  return std::move(scene->nodes.front().mesh);
}

}  // namespace

Status TileHierarchy::build_leaves(Build& b, SceneCache& scenes) {
  // Which keyframes each dirty leaf holds, in seq order.
  std::map<TileKey, std::vector<KeyframeId>> holders;
  for (const auto& [seq, e] : b.keyframes)
    for (const auto& leaf : e.leaves)
      if (b.dirty.count(leaf)) holders[leaf].push_back({seq, e.rev});
  std::set<TileKey> parents;
  for (const TileKey& leaf : b.dirty) {
    parents.insert(leaf.parent());
    std::vector<std::shared_ptr<const Scene>> held;  // alive while the leaf is built, whatever the cache drops
    std::vector<const Scene*> keyframes;
    for (const auto& id : holders[leaf]) {
      auto scene = scenes.get(id);
      if (!scene) return scene.error();
      held.push_back(*scene);
      keyframes.push_back(held.back().get());
    }
    auto mesh = keyframes.empty() ? Result<Mesh>(make_error(ErrorCode::kEmpty, "no keyframe"))
                                  : build_leaf(keyframes, leaf, options_.leaf_size_m, options_.leaf);
    if (auto st = store_tile(b, leaf, std::move(mesh), TileRecord{}, &b.stats.leaves_built); !st) return st;
  }
  b.dirty = std::move(parents);
  return ok_status();
}

Status TileHierarchy::build_inner_levels(Build& b) {
  for (int level = 1; level <= options_.top_level; ++level) {
    std::set<TileKey> parents;
    for (const TileKey& key : b.dirty) {
      parents.insert(key.parent());
      std::vector<Mesh> children;
      std::vector<const TileRecord*> child_records;
      for (std::int64_t dx = 0; dx < 2; ++dx)
        for (std::int64_t dz = 0; dz < 2; ++dz) {
          auto it = b.tiles.find(TileKey{level - 1, 2 * key.x + dx, 2 * key.z + dz});
          if (it == b.tiles.end()) continue;
          auto mesh = read_tile(dir_, it->second);
          if (!mesh) return mesh.error();
          children.push_back(std::move(*mesh));
          child_records.push_back(&it->second);
        }
      TileRecord r;  // holds its children's boxes, and its error covers theirs
      double child_error = 0.0;
      for (const TileRecord* c : child_records) {
        child_error = std::max(child_error, c->geometric_error_m);
        r.box.extend(c->box);
      }
      std::vector<const Mesh*> inputs;
      for (const auto& m : children) inputs.push_back(&m);
      auto inner = inputs.empty() ? Result<InnerTile>(make_error(ErrorCode::kEmpty, "no child"))
                                  : build_inner(inputs, child_error, options_.inner_triangles, level == 1,
                                                options_.inner);
      r.geometric_error_m = child_error + (inner ? inner->simplify_error_m : 0.0);
      auto mesh = inner ? Result<Mesh>(std::move(inner->mesh)) : Result<Mesh>(inner.error());
      if (auto st = store_tile(b, key, std::move(mesh), r, &b.stats.inner_built); !st) return st;
    }
    b.dirty = std::move(parents);
  }
  return ok_status();
}

// Tile `key` of this build: `content` written as its GLB and recorded (record's version, size, triangles set here,
// its box grown to hold the content; ++*built), or the tile removed when content is kEmpty.
Status TileHierarchy::store_tile(Build& b, const TileKey& key, Result<Mesh> content, TileRecord record, size_t* built) {
  if (!content && content.error().code == ErrorCode::kEmpty) {
    b.stats.tiles_removed += b.tiles.erase(key);
    return ok_status();
  }
  if (!content) return make_error(content.error().code, "tile " + key.name() + ": " + content.error().message);
  record.key = key;
  record.version = b.version;
  if (auto st = write_tile(dir_, std::move(*content), &record); !st) return st;
  b.stats.bytes_written += record.bytes;
  b.tiles[key] = record;
  ++*built;
  return ok_status();
}

Status TileHierarchy::commit(Build& b) {
  nlohmann::json keyframes = nlohmann::json::array(), tiles = nlohmann::json::array();
  for (const auto& [seq, e] : b.keyframes) {
    nlohmann::json leaves = nlohmann::json::array();
    for (const auto& k : e.leaves) leaves.push_back(k.name());
    keyframes.push_back({seq, e.rev, std::move(leaves)});
  }
  for (const auto& [key, r] : b.tiles)
    tiles.push_back({key.name(), r.version, r.box.min().x(), r.box.min().y(), r.box.min().z(), r.box.max().x(),
                     r.box.max().y(), r.box.max().z(), r.geometric_error_m, r.triangles, r.bytes, r.render_bytes});
  const nlohmann::json manifest = {{"format", kFormat},      {"version", b.version}, {"options", options_json(options_)},
                                   {"keyframes", keyframes}, {"tiles", tiles}};
  const std::string text = manifest.dump();
  if (auto st = glb::write_file_atomically(dir_ + "/" + kManifest, std::vector<std::uint8_t>(text.begin(), text.end()));
      !st)
    return st;
  // Committed. The previous version's files stay for clients that read its tileset; the ones before it go.
  std::set<std::string> now;
  for (const auto& [key, r] : b.tiles) now.insert(r.file());
  std::error_code ec;
  for (const auto& f : retired_)
    if (!now.count(f)) fs::remove(dir_ + "/" + f, ec);
  retired_.clear();
  for (const auto& [key, r] : tiles_)
    if (!now.count(r.file())) retired_.insert(r.file());
  version_ = b.version;
  tiles_ = std::move(b.tiles);
  keyframes_ = std::move(b.keyframes);
  publish();
  return ok_status();
}

void TileHierarchy::publish() {
  auto s = std::make_shared<TilesetSnapshot>();
  s->version = version_;
  s->tileset_json = make_tileset(tiles_, options_.top_level, version_, "tiles/").dump();
  s->records = tiles_;
  for (const auto& [seq, k] : keyframes_) s->keyframes.emplace(seq, k.rev);
  s->top_level = options_.top_level;
  for (const auto& [key, r] : tiles_) {
    s->files[r.file()] = r.bytes;
    ++s->tiles;
    s->triangles += r.triangles;
    s->bytes += r.bytes;
  }
  std::error_code ec;
  for (const auto& f : retired_) {
    const auto size = fs::file_size(dir_ + "/" + f, ec);
    if (!ec) s->files.emplace(f, size);
  }
  std::lock_guard lock(snapshot_mutex_);
  snapshot_ = std::move(s);
}

std::shared_ptr<const TilesetSnapshot> TileHierarchy::snapshot() const {
  std::lock_guard lock(snapshot_mutex_);
  return snapshot_;
}

}  // namespace rgbdcast::tiles
