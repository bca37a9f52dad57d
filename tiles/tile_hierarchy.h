#pragma once
// A mission's live level-of-detail hierarchy: a quadtree of tiles over the floor (tiles/tile_key.h) whose leaves are
// the keyframes' surfaces and whose inner tiles hold their children's, simplified (tiles/tile_content.h), served as
// an OGC 3D Tiles 1.1 tileset (tiles/tileset_json.h) with GLB content and REPLACE refinement.
//
// In a TileStorage (tiles/tile_storage.h: a folder, or rows of a database shared by replicas): one GLB per tile
// version, "<name>.v<version>.glb" (immutable: a tile that changes is written under the new version's name), and the
// record, the commit marker (in a folder, hierarchy.json): the version, the options, every tile's record and the
// leaf of each keyframe. Contract:
// - Each commit writes the changed tiles' files first, then the record (TileStorage::commit). A crash (kill -9) at
//   any point leaves the last committed hierarchy whole: open() serves it and collects what a cut update left (files
//   no committed record names). An update that fails or stops deletes the files it wrote.
// - A commit the storage refuses because another writer committed a newer hierarchy (replicas sharing a database)
//   fails the call and marks this hierarchy superseded(): it changes nothing more, and its owner opens it again.
// - After a commit, the files of the version before it stay (a client that read the previous tileset can still fetch
//   its tiles); older ones are deleted.
// - Incremental: a new keyframe, a revision that replaces one (a higher rev of a seq), or a keyframe gone, builds or
//   removes its own leaf only; every ancestor of a changed leaf becomes stale (its box grown to hold the leaf) until
//   it is built again from its children. A stale tile is drawn by nobody: views and clients refine through it
//   (tiles/tile_selection.h, tiles/tileset_json.h), so a keyframe is in the tileset as soon as its leaf is committed,
//   and no view shows a coarse tile that lacks it.
// - Newer keyframes supersede what they cover (TilingOptions::supersede, tiles/tile_cover.h): a leaf holds its
//   keyframe's surface less the triangles that keyframes of a higher seq saw again, and a keyframe they cover whole
//   has no leaf. A new keyframe trims the older leaves it overlaps (their leaves built again); a keyframe replaced
//   or gone has the older keyframes it covered worked out again from all the newer ones that overlap them.
// - Every build is a function of its inputs (a leaf: its keyframe and the newer keyframes that overlap it; an inner
//   tile: its children's stored GLBs, built only once none of them is stale), so a hierarchy with no stale tile has
//   the same contents however it was reached.
// - Every tile's geometric error is in metres and at least each of its children's; leaves' is 0.
// Not thread-safe, except snapshot() and build_tile(), which any thread may call while another call runs.
#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "gltf/gltf_io.h"
#include "scene/result.h"
#include "scene/scene.h"
#include "tiles/tile_content.h"
#include "tiles/tile_cover.h"
#include "tiles/tile_key.h"
#include "tiles/tile_storage.h"

namespace rgbdcast::tiles {

struct TilingOptions {
  double leaf_size_m = 2.0;        // side of a leaf's floor cell
  int top_level = 6;               // the tree's top tiles: cells of leaf_size_m * 2^top_level (128 m by default)
  size_t inner_triangles = 20000;  // an inner tile keeps at most this many (and a quarter of its children's)
  // When > 0, an inner tile's edge collapses stop where their error would pass this fraction of the tile's cell side,
  // so that errors grow with the cells level by level. Off by default: on the children of level-3 tiles of a
  // 5,000-keyframe exploration a quarter of the triangles cost 0.89-0.91 m of error, and 0.01 (0.16 m there) keeps
  // 8-9 % more; a default overview (1 px) then draws the vertex-coloured level-3 and 4 tiles instead of the textured
  // level-2 ones, in 67.5 ms instead of 162.5 at 5,000 keyframes, but scores 20.7 dB against full detail instead of
  // 24.8 (26.7 against 28.3 at 1,000), on code that could still drop a branch of small tiles (BENCHMARKS.md).
  double inner_error_per_side = 0.0;
  LeafBakeOptions leaf;
  InnerBakeOptions inner;
  // Draco, the keyframes' own codec: a leaf's geometry then takes what its keyframe GLB took (meshopt: 2.4x more on
  // TUM keyframes); three.js (DRACOLoader) and decode_glb read it.
  GeometryCodec geometry = GeometryCodec::kDraco;
  // Newer keyframes supersede the older surface they cover (tiles/tile_cover.h), so that a place seen on many passes
  // holds about one surface, not one per pass. Off: every keyframe's whole surface is a leaf.
  bool supersede = true;
  CoverOptions cover;
  // step() builds a stale tile again once nothing under it changed for settle_s (a tile that keyframes keep changing
  // is not built over and over: a burst of keyframes costs one build), or once it has been stale for max_stale_s
  // however often it changes (so the tiles over a robot that keeps posting are still built now and then). Neither
  // changes what is built, only when.
  double settle_s = 1.0;
  double max_stale_s = 30.0;
};

struct KeyframeId {
  std::int64_t seq = 0, rev = 0;
  auto operator<=>(const KeyframeId&) const = default;
};

struct TileRecord {
  TileKey key;
  std::uint64_t version = 0;  // the hierarchy version that wrote its GLB
  Eigen::AlignedBox3d box;    // world frame (OpenCV axes): holds its content and its children's boxes
  double geometric_error_m = 0.0;
  std::uint64_t triangles = 0, bytes = 0;
  std::uint64_t render_bytes = 0;  // what a renderer holds for it (scene/render_bytes.h)
  // An inner tile whose children changed since its content was built, or that has none yet (version 0): its content
  // is not drawn, and its box and error are only bounds.
  bool stale = false;
  bool has_content() const { return version > 0; }
  std::string file() const;  // "<name>.v<version>.glb"
};

// The records of `key`'s children in `tiles`, in key order: for a level-1 tile the leaves in its four cells, above it
// the four tiles below that are present.
std::vector<const TileRecord*> children_of(const std::map<TileKey, TileRecord>& tiles, const TileKey& key);

// What clients read, made at each commit.
struct TilesetSnapshot {
  std::uint64_t version = 0;
  std::string tileset_json;                           // 3D Tiles 1.1, tile URIs relative to it ("tiles/<file>")
  std::map<std::string, std::uint64_t> files;         // tile file name -> bytes, this version's and the previous one's
  std::uint64_t tiles = 0, triangles = 0, bytes = 0;  // this version's
  std::uint64_t stale = 0;  // this version's inner tiles still to be rebuilt (drawn from their descendants meanwhile)
  std::map<TileKey, TileRecord> records;           // this version's tiles (what a view selects from)
  std::map<std::int64_t, std::int64_t> keyframes;  // seq -> rev of the keyframes this version holds
  int top_level = 0;
};

// The placed keyframe (its nodes in the mission's world frame) of (seq, rev).
using KeyframeLoader = std::function<Result<Scene>(const KeyframeId&)>;

struct UpdateStats {
  std::uint64_t version = 0;
  size_t keyframes_changed = 0;  // added, replaced or removed
  size_t leaves_built = 0, inner_built = 0, tiles_removed = 0;
  size_t leaves_trimmed = 0;  // older keyframes of which newer ones covered more (their leaves built again)
  std::uint64_t bytes_written = 0;
  size_t stale = 0;  // inner tiles still stale when the call returned
  // When stale > 0: the earliest time (the caller's clock, as step()'s now_s) at which a step can build one of them.
  double next_sweep_s = 0.0;
};

class TileHierarchy {
 public:
  // Opens (or creates) the hierarchy in `storage`. A record that does not parse, or one made with other options, is
  // started again from empty (its files collected), its versions going on from the stored one. The storage's errors
  // (kIo: the folder cannot be made or read; kUnavailable: the database cannot be reached).
  static Result<std::unique_ptr<TileHierarchy>> open(std::shared_ptr<TileStorage> storage,
                                                     const TilingOptions& options);
  // The directory store in `dir`.
  static Result<std::unique_ptr<TileHierarchy>> open(const std::string& dir, const TilingOptions& options);
  ~TileHierarchy();

  // Brings the hierarchy to `keyframes` (the mission's current keyframes, one rev per seq) and builds every stale
  // tile, in one commit when anything changed (else returns the current version and changes nothing). A keyframe
  // that fails to load or build fails the update (kept uncommitted: the previous version stays served), naming the
  // keyframe or tile. `stop`, when given and set, ends the update between two tiles (kUnavailable, uncommitted, as a
  // crash would leave it): a server shutting down does not wait for a long update.
  Result<UpdateStats> update(const std::vector<KeyframeId>& keyframes, const KeyframeLoader& load,
                             const std::atomic<bool>* stop = nullptr);

  // One step of a live hierarchy, at most one commit, for a server that must show new keyframes at once. now_s is
  // the caller's clock in seconds (monotonic; injected, so that tests choose it):
  // - when `keyframes` differ from the committed ones, their leaves only (their ancestors made stale at now_s);
  // - else a sweep over the stale tiles that are due (TilingOptions::settle_s, max_stale_s), lowest level first,
  //   each built once its children are all fresh, until none is left or `yield` (when given) returns true after a
  //   tile: new keyframes wait. The next sweep goes on from the level where this one yielded, so every level is
  //   reached however often keyframes arrive. A sweep that builds nothing commits nothing.
  // UpdateStats::stale says how many stale tiles remain, next_sweep_s when to step again. Tiles that were stale when
  // the hierarchy was opened are due at once. Errors as update()'s.
  Result<UpdateStats> step(const std::vector<KeyframeId>& keyframes, const KeyframeLoader& load, double now_s,
                           const std::atomic<bool>* stop = nullptr, const std::function<bool()>& yield = nullptr);

  // step()'s first half alone: the leaves of changed keyframes (nothing when none changed, and no commit).
  Result<UpdateStats> add_leaves(const std::vector<KeyframeId>& keyframes, const KeyframeLoader& load, double now_s,
                                 const std::atomic<bool>* stop = nullptr);

  // step()'s sweep, one tile at a time and off the caller's thread, for a server whose new keyframes must never wait
  // for a tile build: next_build() picks what a sweep would build next (a due stale tile whose children are fresh;
  // nullopt when none is due), build_tile() writes its file from what the pick copied (it reads no mutable member:
  // any thread may run it while add_leaves() commits), and finish_build() commits it, unless its children changed
  // meanwhile (the file is then deleted and the tile stays stale). Every call but build_tile() needs the same
  // exclusion as step().
  struct PendingBuild {
    TileKey key;
    std::uint64_t file_version = 0;    // the version in its file name
    std::vector<TileRecord> children;  // as they were when it was picked
  };
  std::optional<PendingBuild> next_build(double now_s) const;
  // The committed hierarchy's stale count and when its next stale tile is due (UpdateStats::stale, next_sweep_s).
  UpdateStats status(double now_s) const;
  Result<TileRecord> build_tile(const PendingBuild& pending) const;
  Result<UpdateStats> finish_build(const PendingBuild& pending, Result<TileRecord> built, double now_s);

  std::uint64_t version() const { return version_; }
  const std::map<TileKey, TileRecord>& tiles() const { return tiles_; }
  // seq -> (rev, its leaf), as committed.
  struct KeyframeEntry {
    std::int64_t rev = 0;
    std::vector<TileKey> leaves;           // its one leaf; none for a keyframe without triangles, or covered whole
    Eigen::AlignedBox3d box;               // its whole surface's (tiles/tile_cover.h: cover_box)
    std::vector<std::int64_t> covered_by;  // the newer keyframes that cover any of its triangles, ascending
    // Which of its triangles they cover (mark_covered's order). Not stored: null when none is covered, or, with
    // covered_by not empty, when not worked out since the hierarchy was opened.
    std::shared_ptr<const std::vector<bool>> covered;
  };
  const std::map<std::int64_t, KeyframeEntry>& keyframes() const { return keyframes_; }
  TileStorage& storage() const { return *storage_; }
  // A commit was refused: the storage holds a newer hierarchy than this one (open it again).
  bool superseded() const { return superseded_; }
  const TilingOptions& options() const { return options_; }
  std::shared_ptr<const TilesetSnapshot> snapshot() const;

 private:
  TileHierarchy(std::shared_ptr<TileStorage> storage, TilingOptions options);
  struct Build;
  class SceneCache;
  class CoverCache;
  Status load_committed(const std::vector<std::uint8_t>& record);
  Build begin_build() const;
  Status apply_keyframes(Build& b, const std::vector<KeyframeId>& wanted, SceneCache& scenes,
                         const std::atomic<bool>* stop);
  // Supersession after apply_keyframes: `added` (new or replacing, ascending) trim the older keyframes they
  // overlap; the keyframes that a `gone` one (replaced or removed) covered are worked out again. `stop` ends it
  // between two keyframes.
  Status supersede(Build& b, const std::vector<std::int64_t>& added, const std::vector<std::int64_t>& gone,
                   SceneCache& scenes, const std::atomic<bool>* stop);
  // Keyframe `seq`'s coverage from every newer keyframe of the build that overlaps it (but those in `skip`); its
  // leaf to build again.
  Status cover_again(Build& b, std::int64_t seq, SceneCache& scenes, const std::set<std::int64_t>* skip = nullptr);
  Result<std::shared_ptr<const CoverDepth>> depth_of(const KeyframeId& id, SceneCache& scenes);
  Status build_leaves(Build& b, SceneCache& scenes, const std::atomic<bool>* stop);
  void mark_ancestors_stale(Build& b, const TileKey& leaf);
  // Builds the stale tiles `due` accepts (all when it is empty).
  Status sweep_stale(Build& b, const std::atomic<bool>* stop, const std::function<bool()>& yield,
                     const std::function<bool(const TileKey&)>& due);
  double due_at(const TileKey& key) const;
  Status build_inner(Build& b, const TileKey& key);
  Result<TileRecord> make_inner(const TileKey& key, const std::vector<TileRecord>& children,
                                std::uint64_t version) const;
  Status put_inner(Build& b, const TileKey& key, Result<TileRecord> built);
  UpdateStats summarize(const std::map<TileKey, TileRecord>& tiles, UpdateStats stats, double now_s) const;
  Status store_tile(Build& b, const TileKey& key, Result<SceneNode> content, TileRecord record, size_t* built);
  Status commit(Build& b);
  void publish();

  std::shared_ptr<TileStorage> storage_;
  TilingOptions options_;
  bool superseded_ = false;
  std::uint64_t version_ = 0;
  std::map<TileKey, TileRecord> tiles_;
  std::map<std::int64_t, KeyframeEntry> keyframes_;
  std::unique_ptr<CoverCache>
      covers_;  // the newer keyframes' depths, the most recent 64 (two layers of 320 x 240: 40 MB)
  std::map<std::string, std::uint64_t> retired_;  // files (-> bytes) of the previous version the current one lacks
  int sweep_level_ = 1;                           // where step()'s next sweep starts
  struct StaleSince {
    double first_s = 0.0, last_s = 0.0;  // when the tile became stale, and when something under it last changed
  };
  std::map<TileKey, StaleSince> stale_since_;  // step()'s clock; a stale tile without an entry is due at once
  mutable std::mutex snapshot_mutex_;
  std::shared_ptr<const TilesetSnapshot> snapshot_;
};

}  // namespace rgbdcast::tiles
