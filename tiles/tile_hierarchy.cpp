#include "tiles/tile_hierarchy.h"

#include <algorithm>
#include <cmath>
#include <list>
#include <memory>
#include <utility>

#include <nlohmann/json.hpp>

#include "gltf/gltf_io.h"
#include "scene/render_bytes.h"
#include "tiles/tileset_json.h"

namespace rgbdcast::tiles {
namespace {

constexpr int kFormat = 8;  // 2: inner tiles are textured; 3: their texels at least twice their children's;
                            // 4: records carry render bytes; 5: keyframes are the leaves, inner tiles can be stale;
                            // 6: inner tiles keep one layer where children overlap; 7: newer keyframes supersede;
                            // 8: inner tiles clustered where edge collapses stall (and an error limit)

nlohmann::json options_json(const TilingOptions& o) {
  return {{"leaf_size_m", o.leaf_size_m},
          {"top_level", o.top_level},
          {"inner_triangles", o.inner_triangles},
          {"inner_error_per_side", o.inner_error_per_side},
          {"leaf_max_atlas_side_px", o.leaf.max_atlas_side_px},
          {"leaf_gutter_px", o.leaf.gutter_px},
          {"leaf_jpeg_quality", o.leaf.jpeg_quality},
          {"inner_max_atlas_side_px", o.inner.atlas.max_atlas_side_px},
          {"inner_gutter_px", o.inner.atlas.gutter_px},
          {"inner_jpeg_quality", o.inner.atlas.jpeg_quality},
          {"inner_texels_per_error", o.inner.texels_per_error},
          {"inner_min_leg_texels", o.inner.min_leg_texels},
          {"inner_min_layer_voxel_m", o.inner.min_layer_voxel_m},
          {"geometry", to_string(o.geometry)},
          {"supersede", o.supersede},
          {"cover_depth_tolerance_m", o.cover.depth_tolerance_m},
          {"cover_max_range_ratio", o.cover.max_range_ratio},
          {"cover_downscale", o.cover.downscale}};
}

Status stopped(const std::atomic<bool>* stop) {
  if (stop && stop->load()) return make_error(ErrorCode::kUnavailable, "tiles: stopped before the update committed");
  return ok_status();
}

// The quantization step of a tile's positions bounds how far its stored vertices are from the exact ones: the box
// is grown by it so that it holds the GLB's (dequantized) positions. encode_glb's step is 1 mm, or extent / 65,535.
double position_pad_m(const Eigen::AlignedBox3d& box) {
  return box.isEmpty() ? 0.001 : std::max(0.001, (box.max() - box.min()).maxCoeff() / 32767.0);
}

}  // namespace

namespace {

// What was made for the most recent few keyframes, most recent first: the scenes an update decoded, the depths that
// trim older keyframes. A value is shared: a caller that holds it keeps it alive after the cache drops it.
template <class T>
class RecentKeyframes {
 public:
  explicit RecentKeyframes(size_t keep) : keep_(keep) {}
  std::shared_ptr<const T> find(const KeyframeId& id) {
    for (auto it = entries_.begin(); it != entries_.end(); ++it)
      if (it->first == id) {
        entries_.splice(entries_.begin(), entries_, it);
        return entries_.front().second;
      }
    return nullptr;
  }
  std::shared_ptr<const T> put(const KeyframeId& id, std::shared_ptr<const T> value) {
    entries_.emplace_front(id, std::move(value));
    if (entries_.size() > keep_) entries_.pop_back();
    return entries_.front().second;
  }

 private:
  size_t keep_;
  std::list<std::pair<KeyframeId, std::shared_ptr<const T>>> entries_;
};

}  // namespace

// The placed keyframes one update reads, decoded (a leaf seen by more keyframes than the cache keeps still works).
class TileHierarchy::SceneCache {
 public:
  SceneCache(const KeyframeLoader& load, size_t keep) : load_(load), recent_(keep) {}
  Result<std::shared_ptr<const Scene>> get(const KeyframeId& id) {
    if (auto cached = recent_.find(id)) return cached;
    auto scene = load_(id);
    if (!scene)
      return make_error(scene.error().code, "keyframe " + std::to_string(id.seq) + " rev " + std::to_string(id.rev) +
                                                ": " + scene.error().message);
    return recent_.put(id, std::make_shared<const Scene>(std::move(*scene)));
  }

 private:
  const KeyframeLoader& load_;
  RecentKeyframes<Scene> recent_;
};

// The depths of the keyframes that trim older ones (a newer keyframe is asked for once per older one it overlaps,
// and again when one of those is worked out from scratch).
class TileHierarchy::CoverCache : public RecentKeyframes<CoverDepth> {
 public:
  using RecentKeyframes::RecentKeyframes;
};

std::string TileRecord::file() const { return key.name() + ".v" + std::to_string(version) + ".glb"; }

std::vector<const TileRecord*> children_of(const std::map<TileKey, TileRecord>& tiles, const TileKey& key) {
  std::vector<const TileRecord*> out;
  if (key.level == 0) return out;
  for (std::int64_t dx = 0; dx < 2; ++dx)
    for (std::int64_t dz = 0; dz < 2; ++dz) {
      const TileKey cell{key.level - 1, 2 * key.x + dx, 2 * key.z + dz, INT64_MIN};
      for (auto it = tiles.lower_bound(cell);
           it != tiles.end() && it->first.level == cell.level && it->first.x == cell.x && it->first.z == cell.z; ++it)
        out.push_back(&it->second);
    }
  return out;
}

// One commit in the making: the new state, built beside the committed one. The files it wrote are deleted when it
// ends uncommitted (an error, a stop), so that a retry may write other bytes under the same names.
struct TileHierarchy::Build {
  explicit Build(TileStorage* s) : storage(s) {}
  Build(Build&& o) noexcept  // begin_build() returns one; o then owns no file
      : storage(o.storage),
        written(std::exchange(o.written, {})),
        version(o.version),
        tiles(std::move(o.tiles)),
        keyframes(std::move(o.keyframes)),
        leaves(std::move(o.leaves)),
        restaled(std::move(o.restaled)),
        built(std::move(o.built)),
        stats(o.stats) {}
  Build& operator=(const Build&) = delete;
  ~Build() {
    if (!written.empty()) (void)storage->delete_tiles(written);
  }
  TileStorage* storage;
  std::set<std::string> written;  // uncommitted files
  std::uint64_t version = 0;
  std::map<TileKey, TileRecord> tiles;
  std::map<std::int64_t, KeyframeEntry> keyframes;
  std::set<TileKey> leaves;    // leaves to build again or remove
  std::set<TileKey> restaled;  // inner tiles that build_leaves made stale
  std::set<TileKey> built;     // inner tiles built again (or removed)
  UpdateStats stats;
};

Result<std::unique_ptr<TileHierarchy>> TileHierarchy::open(const std::string& dir, const TilingOptions& options) {
  auto storage = directory_tile_storage(dir);
  if (!storage) return storage.error();
  return open(std::shared_ptr<TileStorage>(std::move(*storage)), options);
}

Result<std::unique_ptr<TileHierarchy>> TileHierarchy::open(std::shared_ptr<TileStorage> storage,
                                                           const TilingOptions& options) {
  if (!(options.leaf_size_m > 0.0) || options.top_level < 1 || options.top_level > 30 || options.inner_triangles == 0)
    return make_error(ErrorCode::kInvalidArgument, "tiles: leaf_size_m > 0, top_level 1..30, inner_triangles > 0");
  std::unique_ptr<TileHierarchy> h(new TileHierarchy(std::move(storage), options));
  auto record = h->storage_->read_record();
  if (!record) return record.error();
  if (*record && !h->load_committed((*record)->bytes)) {  // unreadable or made with other options: start again
    h->tiles_.clear();
    h->keyframes_.clear();
    h->version_ = (*record)->version;  // after the stored one, which the storage compares with
  }
  // Whatever the committed record does not name is a cut update's (or an older version's).
  std::set<std::string> named;
  for (const auto& [key, r] : h->tiles_)
    if (r.has_content()) named.insert(r.file());
  if (auto st = h->storage_->collect(named, h->version_); !st) return st.error();
  h->publish();
  return h;
}

TileHierarchy::TileHierarchy(std::shared_ptr<TileStorage> storage, TilingOptions options)
    : storage_(std::move(storage)), options_(std::move(options)), covers_(std::make_unique<CoverCache>(64)) {}

TileHierarchy::~TileHierarchy() = default;

Status TileHierarchy::load_committed(const std::vector<std::uint8_t>& record) {
  const std::string path = storage_->where();
  const auto j = nlohmann::json::parse(record.begin(), record.end(), nullptr, false);
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
      const auto& box = k.at(3);
      e.box = Eigen::AlignedBox3d(Eigen::Vector3d(box.at(0), box.at(1), box.at(2)),
                                  Eigen::Vector3d(box.at(3), box.at(4), box.at(5)));
      e.covered_by = k.at(4).get<std::vector<std::int64_t>>();
      keyframes_[k.at(0).get<std::int64_t>()] = std::move(e);
    }
    for (const auto& t : j.at("tiles")) {
      auto key = parse_tile_key(t.at(0).get<std::string>());
      if (!key) return make_error(ErrorCode::kInvalidInput, "tiles: bad tile name in " + path);
      TileRecord r;
      r.key = *key;
      r.version = t.at(1).get<std::uint64_t>();
      r.box =
          Eigen::AlignedBox3d(Eigen::Vector3d(t.at(2), t.at(3), t.at(4)), Eigen::Vector3d(t.at(5), t.at(6), t.at(7)));
      r.geometric_error_m = t.at(8).get<double>();
      r.triangles = t.at(9).get<std::uint64_t>();
      r.bytes = t.at(10).get<std::uint64_t>();
      r.render_bytes = t.at(11).get<std::uint64_t>();
      r.stale = t.at(12).get<bool>();
      tiles_[r.key] = r;
    }
  } catch (const nlohmann::json::exception&) {
    return make_error(ErrorCode::kInvalidInput, "tiles: " + path + " has a field of the wrong type");
  }
  return ok_status();
}

TileHierarchy::Build TileHierarchy::begin_build() const {
  Build b(storage_.get());
  b.version = version_ + 1;
  b.tiles = tiles_;
  b.keyframes = keyframes_;
  b.stats.version = version_;
  return b;
}

namespace {
size_t count_stale(const std::map<TileKey, TileRecord>& tiles) {
  return std::count_if(tiles.begin(), tiles.end(), [](const auto& kv) { return kv.second.stale; });
}
}  // namespace

Status TileHierarchy::apply_keyframes(Build& b, const std::vector<KeyframeId>& wanted, SceneCache& scenes,
                                      const std::atomic<bool>* stop) {
  std::map<std::int64_t, std::int64_t> want;
  for (const auto& k : wanted) want[k.seq] = k.rev;
  std::vector<std::int64_t> gone, added;
  // Keyframes gone or replaced: their leaves go (a replacement's is built again below).
  for (auto it = b.keyframes.begin(); it != b.keyframes.end();) {
    auto w = want.find(it->first);
    if (w != want.end() && w->second == it->second.rev) {
      ++it;
      continue;
    }
    gone.push_back(it->first);
    b.leaves.insert(it->second.leaves.begin(), it->second.leaves.end());
    ++b.stats.keyframes_changed;
    it = b.keyframes.erase(it);
  }
  for (const auto& [seq, rev] : want) {
    if (b.keyframes.count(seq)) continue;
    auto scene = scenes.get({seq, rev});
    if (!scene) return scene.error();
    KeyframeEntry e;
    e.rev = rev;
    if (auto leaf = keyframe_leaf(**scene, seq, options_.leaf_size_m)) e.leaves.push_back(*leaf);
    e.box = cover_box(**scene, options_.cover);
    b.leaves.insert(e.leaves.begin(), e.leaves.end());
    if (!keyframes_.count(seq)) ++b.stats.keyframes_changed;
    b.keyframes[seq] = std::move(e);
    added.push_back(seq);
  }
  if (!options_.supersede) return ok_status();
  return supersede(b, added, gone, scenes, stop);
}

Result<std::shared_ptr<const CoverDepth>> TileHierarchy::depth_of(const KeyframeId& id, SceneCache& scenes) {
  if (auto cached = covers_->find(id)) return cached;
  auto scene = scenes.get(id);
  if (!scene) return scene.error();
  auto depth = cover_depth(**scene, options_.cover);
  // A keyframe without a camera or a surface in front of it covers nothing: an empty depth says so.
  auto shared = std::make_shared<const CoverDepth>(depth ? std::move(*depth) : CoverDepth{});
  covers_->put(id, shared);
  return shared;
}

namespace {
// `covered` with what `more` marks added; whether anything was.
bool add_covered(std::vector<bool>& covered, const std::vector<bool>& more) {
  bool changed = false;
  if (covered.size() < more.size()) covered.resize(more.size(), false);
  for (size_t i = 0; i < more.size(); ++i)
    if (more[i] && !covered[i]) covered[i] = changed = true;
  return changed;
}
bool all_covered(const std::vector<bool>& covered) {
  return !covered.empty() && std::all_of(covered.begin(), covered.end(), [](bool c) { return c; });
}
}  // namespace

Status TileHierarchy::cover_again(Build& b, std::int64_t seq, SceneCache& scenes, const std::set<std::int64_t>* skip) {
  KeyframeEntry& e = b.keyframes.at(seq);
  auto scene = scenes.get({seq, e.rev});
  if (!scene) return scene.error();
  auto covered = std::make_shared<std::vector<bool>>();
  e.covered_by.clear();
  for (auto it = b.keyframes.upper_bound(seq); it != b.keyframes.end(); ++it) {
    if ((skip && skip->count(it->first)) || !it->second.box.intersects(e.box)) continue;
    auto depth = depth_of({it->first, it->second.rev}, scenes);
    if (!depth) return depth.error();
    if ((*depth)->depth_m.empty()) continue;
    std::vector<bool> by;
    if (mark_covered(**scene, **depth, options_.cover, by) == 0) continue;
    e.covered_by.push_back(it->first);
    add_covered(*covered, by);
  }
  b.leaves.insert(e.leaves.begin(), e.leaves.end());
  e.leaves.clear();
  if (!all_covered(*covered))
    if (auto leaf = keyframe_leaf(**scene, seq, options_.leaf_size_m)) e.leaves.push_back(*leaf);
  b.leaves.insert(e.leaves.begin(), e.leaves.end());
  e.covered = e.covered_by.empty() ? nullptr : std::move(covered);
  return ok_status();
}

Status TileHierarchy::supersede(Build& b, const std::vector<std::int64_t>& added, const std::vector<std::int64_t>& gone,
                                SceneCache& scenes, const std::atomic<bool>* stop) {
  const std::set<std::int64_t> fresh(added.begin(), added.end());
  // From scratch, against every newer keyframe: the older ones a gone keyframe covered.
  std::set<std::int64_t> again;
  for (std::int64_t g : gone)
    for (auto& [seq, e] : b.keyframes)
      if (seq < g && !fresh.count(seq) && std::binary_search(e.covered_by.begin(), e.covered_by.end(), g))
        again.insert(seq);
  for (std::int64_t seq : again) {
    if (auto st = stopped(stop); !st) return st;
    if (auto st = cover_again(b, seq, scenes); !st) return st;
  }
  // The added keyframes one by one in seq order, as if they had come so (a batch of n costs n applications, not
  // n^2): each is covered by the newer keyframes that were there before it (none, for the newest), then trims the
  // older ones that still show a surface, the ones added before it included.
  for (std::int64_t j : added) {
    if (auto st = stopped(stop); !st) return st;
    const KeyframeEntry& newer = b.keyframes.at(j);
    for (auto it = b.keyframes.upper_bound(j); it != b.keyframes.end(); ++it)
      if (!fresh.count(it->first) && it->second.box.intersects(newer.box)) {
        if (auto st = cover_again(b, j, scenes, &fresh); !st) return st;
        break;
      }
    std::shared_ptr<const CoverDepth> depth;
    for (auto& [seq, e] : b.keyframes) {
      if (seq >= j) break;
      if (again.count(seq) || e.leaves.empty() || !e.box.intersects(newer.box)) continue;
      if (!e.covered_by.empty() && !e.covered) {  // not worked out since the hierarchy was opened: from scratch
        if (auto st = cover_again(b, seq, scenes); !st) return st;
        again.insert(seq);
        ++b.stats.leaves_trimmed;
        continue;
      }
      if (!depth) {
        auto d = depth_of({j, newer.rev}, scenes);
        if (!d) return d.error();
        depth = *d;
      }
      if (depth->depth_m.empty()) break;
      auto scene = scenes.get({seq, e.rev});
      if (!scene) return scene.error();
      std::vector<bool> by;
      if (mark_covered(**scene, *depth, options_.cover, by) == 0) continue;
      e.covered_by.push_back(j);
      std::sort(e.covered_by.begin(), e.covered_by.end());
      auto covered = std::make_shared<std::vector<bool>>(e.covered ? *e.covered : std::vector<bool>());
      if (!add_covered(*covered, by)) {
        e.covered = std::move(covered);
        continue;
      }
      ++b.stats.leaves_trimmed;
      b.leaves.insert(e.leaves.begin(), e.leaves.end());
      if (all_covered(*covered)) e.leaves.clear();
      e.covered = std::move(covered);
    }
  }
  return ok_status();
}

Result<UpdateStats> TileHierarchy::update(const std::vector<KeyframeId>& wanted, const KeyframeLoader& load,
                                          const std::atomic<bool>* stop) {
  Build b = begin_build();
  SceneCache scenes(load, 48);
  if (auto st = apply_keyframes(b, wanted, scenes, stop); !st) return st.error();
  if (b.stats.keyframes_changed == 0 && count_stale(b.tiles) == 0) return b.stats;
  if (auto st = build_leaves(b, scenes, stop); !st) return st.error();
  if (auto st = sweep_stale(b, stop, nullptr, nullptr); !st) return st.error();
  b.stats.stale = count_stale(b.tiles);
  if (auto st = commit(b); !st) return st.error();
  b.stats.version = version_;
  return b.stats;
}

// `stats` with how many of `tiles` stay stale, and when the earliest one whose children are fresh (the ones a sweep
// can build) is due.
UpdateStats TileHierarchy::summarize(const std::map<TileKey, TileRecord>& tiles, UpdateStats stats,
                                     double now_s) const {
  stats.stale = count_stale(tiles);
  stats.next_sweep_s = stats.stale == 0 ? now_s : INFINITY;
  for (const auto& [key, r] : tiles) {
    if (!r.stale) continue;
    const auto children = children_of(tiles, key);
    if (std::none_of(children.begin(), children.end(), [](const TileRecord* c) { return c->stale; }))
      stats.next_sweep_s = std::min(stats.next_sweep_s, std::max(now_s, due_at(key)));
  }
  return stats;
}

double TileHierarchy::due_at(const TileKey& key) const {
  auto it = stale_since_.find(key);
  if (it == stale_since_.end()) return -INFINITY;
  return std::min(it->second.last_s + options_.settle_s, it->second.first_s + options_.max_stale_s);
}

Result<UpdateStats> TileHierarchy::add_leaves(const std::vector<KeyframeId>& wanted, const KeyframeLoader& load,
                                              double now_s, const std::atomic<bool>* stop) {
  Build b = begin_build();
  SceneCache scenes(load, 48);
  if (auto st = apply_keyframes(b, wanted, scenes, stop); !st) return st.error();
  if (b.stats.keyframes_changed > 0) {
    if (auto st = build_leaves(b, scenes, stop); !st) return st.error();
    for (const TileKey& key : b.restaled) {  // changed under it at now_s
      auto [it, added] = stale_since_.try_emplace(key, StaleSince{now_s, now_s});
      if (!added) it->second.last_s = now_s;
    }
  }
  b.stats = summarize(b.tiles, b.stats, now_s);
  if (b.stats.keyframes_changed == 0) return b.stats;
  if (auto st = commit(b); !st) return st.error();
  b.stats.version = version_;
  return b.stats;
}

Result<UpdateStats> TileHierarchy::step(const std::vector<KeyframeId>& wanted, const KeyframeLoader& load, double now_s,
                                        const std::atomic<bool>* stop, const std::function<bool()>& yield) {
  auto leaves = add_leaves(wanted, load, now_s, stop);
  if (!leaves || leaves->keyframes_changed > 0) return leaves;
  Build b = begin_build();
  if (count_stale(b.tiles) > 0) {
    const std::function<bool()> never = [] { return false; };
    const auto due = [&](const TileKey& key) { return due_at(key) <= now_s; };
    if (auto st = sweep_stale(b, stop, yield ? yield : never, due); !st) return st.error();
    // A sweep that went on from a higher level may find nothing to build there: the lowest stale tiles always can be.
    if (b.stats.inner_built + b.stats.tiles_removed == 0)
      if (auto st = sweep_stale(b, stop, yield ? yield : never, due); !st) return st.error();
  }
  b.stats = summarize(b.tiles, b.stats, now_s);
  if (b.stats.keyframes_changed == 0 && b.stats.inner_built + b.stats.tiles_removed == 0) return b.stats;
  if (auto st = commit(b); !st) return st.error();
  b.stats.version = version_;
  return b.stats;
}

namespace {

// Encodes a tile's node as its GLB (compact: quantized, meshopt-compressed; its texture as the mesh holds it) and
// writes it; the record gets its size and triangle count, and its box grows to hold the GLB's positions.
Status write_tile(TileStorage& storage, SceneNode node, GeometryCodec codec, TileRecord* r) {
  Scene scene;
  node.name = "tile_" + r->key.name();
  scene.nodes.push_back(std::move(node));
  GlbWriteOptions options;
  options.geometry_codec = codec;
  auto glb = encode_glb(scene, options);
  if (!glb) return make_error(glb.error().code, "tile " + r->key.name() + ": " + glb.error().message);
  if (auto st = storage.write_tile(r->file(), *glb); !st) return st.error();
  r->bytes = glb->size();
  r->triangles = scene.triangle_count();
  r->render_bytes = render_bytes(scene);
  const SceneNode& n = scene.nodes.front();
  const Eigen::AlignedBox3d local = mesh_box(n.mesh, 0.0);
  const Eigen::AlignedBox3d padded = mesh_box(n.mesh, position_pad_m(local));
  for (int c = 0; c < 8; ++c)  // the world box of the node's (padded) box
    r->box.extend(
        (n.to_world * padded.corner(static_cast<Eigen::AlignedBox3d::CornerType>(c)).homogeneous()).head<3>());
  return ok_status();
}

// A tile's content as its parent reads it, in world coordinates: the stored GLB decoded, whether it was written in
// this update or an earlier one, so that a parent's input does not depend on which.
Result<Mesh> read_tile(const TileStorage& storage, const TileRecord& r) {
  auto bytes = storage.read_tile(r.file());
  if (!bytes) return bytes.error();
  auto scene = decode_glb(bytes->data(), bytes->size());
  if (!scene || scene->nodes.empty())
    return make_error(ErrorCode::kInvalidInput, "tile " + r.key.name() + ": stored GLB does not decode");
  SceneNode& node = scene->nodes.front();
  if (!node.to_world.isIdentity())
    for (auto& p : node.mesh.positions) p = (node.to_world * p.cast<double>().homogeneous()).head<3>().cast<float>();
  return std::move(node.mesh);
}

}  // namespace

Status TileHierarchy::build_leaves(Build& b, SceneCache& scenes, const std::atomic<bool>* stop) {
  for (const TileKey& leaf : b.leaves) {
    if (auto st = stopped(stop); !st) return st;
    auto holder = b.keyframes.find(leaf.keyframe);
    const bool held =
        holder != b.keyframes.end() && !holder->second.leaves.empty() && holder->second.leaves.front() == leaf;
    Result<SceneNode> content = make_error(ErrorCode::kEmpty, "no keyframe");
    if (held) {
      auto scene = scenes.get({leaf.keyframe, holder->second.rev});
      if (!scene) return scene.error();
      const auto& covered = holder->second.covered;
      content = covered ? build_leaf(without_covered(**scene, *covered), leaf.name(), options_.leaf)
                        : build_leaf(**scene, leaf.name(), options_.leaf);
    }
    if (auto st = store_tile(b, leaf, std::move(content), TileRecord{}, &b.stats.leaves_built); !st) return st;
    mark_ancestors_stale(b, leaf);
  }
  b.leaves.clear();
  return ok_status();
}

void TileHierarchy::mark_ancestors_stale(Build& b, const TileKey& leaf) {
  auto it = b.tiles.find(leaf);
  for (TileKey key = leaf.parent(); key.level <= options_.top_level; key = key.parent()) {
    TileRecord& r = b.tiles[key];  // a new one: no content yet (version 0)
    r.key = key;
    r.stale = true;
    b.restaled.insert(key);
    if (it != b.tiles.end()) r.box.extend(it->second.box);
  }
}

// `key`'s content from `children` (their stored GLBs), written as "<key>.v<version>.glb": its record (box holding
// the children's, error covering theirs), or kEmpty when no child or no triangle is left. Reads only storage_ (which
// is thread-safe) and options_, which never change: any thread may run it.
Result<TileRecord> TileHierarchy::make_inner(const TileKey& key, const std::vector<TileRecord>& child_records,
                                             std::uint64_t version) const {
  std::vector<Mesh> children;
  TileRecord r;
  double child_error = 0.0;
  for (const TileRecord& c : child_records) {
    auto mesh = read_tile(*storage_, c);
    if (!mesh) return mesh.error();
    children.push_back(std::move(*mesh));
    child_error = std::max(child_error, c.geometric_error_m);
    r.box.extend(c.box);
  }
  std::vector<const Mesh*> inputs;
  for (const auto& m : children) inputs.push_back(&m);
  if (inputs.empty()) return make_error(ErrorCode::kEmpty, "no child");
  const double cell_side_m = options_.leaf_size_m * std::ldexp(1.0, key.level);
  const SimplifyTarget target{options_.inner_triangles, options_.inner_error_per_side > 0.0
                                                            ? options_.inner_error_per_side * cell_side_m
                                                            : INFINITY};
  auto inner = tiles::build_inner(inputs, child_error, target, options_.inner);
  if (!inner && inner.error().code == ErrorCode::kEmpty) return inner.error();
  if (!inner) return make_error(inner.error().code, "tile " + key.name() + ": " + inner.error().message);
  r.key = key;
  r.version = version;
  r.geometric_error_m = child_error + inner->layer_error_m + inner->simplify_error_m;
  SceneNode node;
  node.mesh = std::move(inner->mesh);
  if (auto st = write_tile(*storage_, std::move(node), options_.geometry, &r); !st) return st.error();
  return r;
}

// Builds `key` again from its children (or removes it when none is left). Its children are fresh.
Status TileHierarchy::build_inner(Build& b, const TileKey& key) {
  std::vector<TileRecord> children;
  for (const TileRecord* c : children_of(b.tiles, key)) children.push_back(*c);
  b.built.insert(key);
  return put_inner(b, key, make_inner(key, children, b.version));
}

// The result of make_inner in the build: recorded, or the tile removed (kEmpty).
Status TileHierarchy::put_inner(Build& b, const TileKey& key, Result<TileRecord> built) {
  if (!built && built.error().code == ErrorCode::kEmpty) {
    b.stats.tiles_removed += b.tiles.erase(key);
    return ok_status();
  }
  if (!built) return built.error();
  b.written.insert(built->file());
  b.stats.bytes_written += built->bytes;
  b.tiles[key] = *built;
  ++b.stats.inner_built;
  return ok_status();
}

std::optional<TileHierarchy::PendingBuild> TileHierarchy::next_build(double now_s) const {
  for (int level = 1; level <= options_.top_level; ++level)
    for (auto it = tiles_.lower_bound(TileKey{level, INT64_MIN, INT64_MIN, INT64_MIN});
         it != tiles_.end() && it->first.level == level; ++it) {
      if (!it->second.stale || due_at(it->first) > now_s) continue;
      const auto children = children_of(tiles_, it->first);
      if (std::any_of(children.begin(), children.end(), [](const TileRecord* c) { return c->stale; })) continue;
      PendingBuild p{it->first, version_ + 1, {}};
      for (const TileRecord* c : children) p.children.push_back(*c);
      return p;
    }
  return std::nullopt;
}

UpdateStats TileHierarchy::status(double now_s) const {
  UpdateStats stats;
  stats.version = version_;
  return summarize(tiles_, stats, now_s);
}

Result<TileRecord> TileHierarchy::build_tile(const PendingBuild& p) const {
  return make_inner(p.key, p.children, p.file_version);
}

Result<UpdateStats> TileHierarchy::finish_build(const PendingBuild& p, Result<TileRecord> built, double now_s) {
  Build b = begin_build();
  // Still the build the hierarchy needs: the tile stale, its children the ones it was made from (none changed, none
  // went stale, none came or went).
  auto self = b.tiles.find(p.key);
  const auto now = children_of(b.tiles, p.key);
  bool same = self != b.tiles.end() && self->second.stale && now.size() == p.children.size();
  for (size_t i = 0; same && i < now.size(); ++i)
    same = now[i]->key == p.children[i].key && now[i]->version == p.children[i].version && !now[i]->stale;
  if (!same) {
    if (built) (void)storage_->delete_tiles({built->file()});
    b.stats = summarize(b.tiles, b.stats, now_s);
    return b.stats;
  }
  if (!built && built.error().code != ErrorCode::kEmpty) {
    stale_since_[p.key] = StaleSince{now_s, now_s};  // tried again once settled, not at once
    return built.error();
  }
  b.built.insert(p.key);
  if (auto st = put_inner(b, p.key, std::move(built)); !st) return st.error();
  b.stats = summarize(b.tiles, b.stats, now_s);
  if (auto st = commit(b); !st) return st.error();
  b.stats.version = version_;
  return b.stats;
}

Status TileHierarchy::sweep_stale(Build& b, const std::atomic<bool>* stop, const std::function<bool()>& yield,
                                  const std::function<bool(const TileKey&)>& due) {
  for (int level = yield ? sweep_level_ : 1; level <= options_.top_level; ++level) {
    std::vector<TileKey> stale;
    for (auto it = b.tiles.lower_bound(TileKey{level, INT64_MIN, INT64_MIN, INT64_MIN});
         it != b.tiles.end() && it->first.level == level; ++it)
      if (it->second.stale && (!due || due(it->first))) stale.push_back(it->first);
    for (const TileKey& key : stale) {
      const auto children = children_of(b.tiles, key);
      if (std::any_of(children.begin(), children.end(), [](const TileRecord* c) { return c->stale; })) continue;
      if (auto st = stopped(stop); !st) return st;
      if (auto st = build_inner(b, key); !st) return st;
      if (yield && yield()) {
        sweep_level_ = level;
        return ok_status();
      }
    }
  }
  sweep_level_ = 1;
  return ok_status();
}

// Tile `key` of this build: `content` written as its GLB and recorded (record's version, size, triangles set here,
// its box grown to hold the content; ++*built), or the tile removed when content is kEmpty.
Status TileHierarchy::store_tile(Build& b, const TileKey& key, Result<SceneNode> content, TileRecord record,
                                 size_t* built) {
  if (!content && content.error().code == ErrorCode::kEmpty) {
    b.stats.tiles_removed += b.tiles.erase(key);
    return ok_status();
  }
  if (!content) return make_error(content.error().code, "tile " + key.name() + ": " + content.error().message);
  record.key = key;
  record.version = b.version;
  if (auto st = write_tile(*storage_, std::move(*content), options_.geometry, &record); !st) return st;
  b.written.insert(record.file());
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
    const nlohmann::json box = {e.box.min().x(), e.box.min().y(), e.box.min().z(),
                                e.box.max().x(), e.box.max().y(), e.box.max().z()};
    keyframes.push_back({seq, e.rev, std::move(leaves), box, e.covered_by});
  }
  for (const auto& [key, r] : b.tiles)
    tiles.push_back({key.name(), r.version, r.box.min().x(), r.box.min().y(), r.box.min().z(), r.box.max().x(),
                     r.box.max().y(), r.box.max().z(), r.geometric_error_m, r.triangles, r.bytes, r.render_bytes,
                     r.stale});
  const nlohmann::json manifest = {{"format", kFormat},
                                   {"version", b.version},
                                   {"options", options_json(options_)},
                                   {"keyframes", keyframes},
                                   {"tiles", tiles}};
  const std::string text = manifest.dump();
  // The previous version's files stay for clients that read its tileset; the ones before it go.
  TileCommit c;
  c.version = b.version;
  c.record.assign(text.begin(), text.end());
  for (const auto& [key, r] : b.tiles)
    if (r.has_content()) c.named.emplace(r.file(), r.bytes);
  std::map<std::string, std::uint64_t> retired;
  for (const auto& [key, r] : tiles_)
    if (r.has_content() && !c.named.count(r.file())) retired.emplace(r.file(), r.bytes);
  for (const auto& [f, bytes] : retired) c.retained.insert(f);
  for (const auto& [f, bytes] : retired_)
    if (!c.named.count(f) && !c.retained.count(f)) c.garbage.insert(f);
  auto committed = storage_->commit(c);
  if (!committed) return committed.error();
  if (!*committed) {
    superseded_ = true;
    return make_error(ErrorCode::kInvalidInput, "tiles: " + storage_->where() +
                                                    " holds a newer hierarchy than version " +
                                                    std::to_string(version_) + " (another writer committed)");
  }
  b.written.clear();
  retired_ = std::move(retired);
  for (const auto& key : b.built) stale_since_.erase(key);
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
    s->stale += r.stale;
    if (!r.has_content()) continue;
    s->files[r.file()] = r.bytes;  // a stale tile's too: a client may hold the tileset that named it
    if (r.stale) continue;
    ++s->tiles;
    s->triangles += r.triangles;
    s->bytes += r.bytes;
  }
  for (const auto& [f, bytes] : retired_) s->files.emplace(f, bytes);
  std::lock_guard lock(snapshot_mutex_);
  snapshot_ = std::move(s);
}

std::shared_ptr<const TilesetSnapshot> TileHierarchy::snapshot() const {
  std::lock_guard lock(snapshot_mutex_);
  return snapshot_;
}

}  // namespace rgbdcast::tiles
