// The tile hierarchy on real keyframes: TUM fr1/xyz frames reduced by the real CLI, placed by their ground-truth
// poses, and laid out in laps along x (as a robot exploring a floor), the way the long-mission benchmark does.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>
#include <thread>

#include "base/atomic_file.h"
#include "gltf/glb_container.h"
#include "gltf/gltf_io.h"
#include "service/mission_scene.h"
#include "tests/common/gltf_validator.h"
#include "tests/common/test_data.h"
#include "tests/service/mission_keyframes.h"
#include "tiles/tile_hierarchy.h"
#include "tiles/tileset_json.h"

namespace rgbdcast::tiles {
namespace {
namespace fs = std::filesystem;

constexpr double kLapStepM = 4.0;

// Keyframes of the excerpt, decoded once, and the placed scene of (frame, lap).
struct Keyframes {
  std::vector<Scene> decoded;
  std::vector<std::array<double, 7>> poses;
  std::vector<size_t> glb_bytes;  // each keyframe file as posted
  std::string error;

  static const Keyframes& get() {
    static const Keyframes k = [] {
      Keyframes out;
      std::string error;
      auto files = test::mission_keyframes({0, 30, 60, 90}, &error);
      if (files.empty()) out.error = error;
      for (const auto& f : files) {
        auto scene = decode_glb(reinterpret_cast<const std::uint8_t*>(f.glb.data()), f.glb.size());
        auto pose = service::parse_mission_pose(f.pose);
        if (!scene || !pose) {
          out.error = "keyframe " + std::to_string(f.frame) + " does not decode";
          break;
        }
        out.decoded.push_back(std::move(*scene));
        out.poses.push_back(*pose);
        out.glb_bytes.push_back(f.glb.size());
      }
      return out;
    }();
    return k;
  }
  size_t size() const { return decoded.size(); }
  // seq = lap * size() + frame index; rev r > 0 uses the next frame's surface at this seq's pose.
  Result<Scene> placed(const KeyframeId& id) const {
    const size_t n = size();
    const size_t i = static_cast<size_t>(id.seq) % n, lap = static_cast<size_t>(id.seq) / n;
    std::array<double, 7> pose = poses[i];
    pose[0] += kLapStepM * static_cast<double>(lap);
    return service::place_keyframe(decoded[(i + static_cast<size_t>(id.rev)) % n], id.seq, pose);
  }
};

#define REQUIRE_KEYFRAMES()                                                \
  do {                                                                     \
    REQUIRE_DATA(test::kMissionExcerpt);                                   \
    ASSERT_TRUE(Keyframes::get().error.empty()) << Keyframes::get().error; \
    ASSERT_EQ(Keyframes::get().size(), 4u);                                \
  } while (0)

std::vector<KeyframeId> first(size_t count) {
  std::vector<KeyframeId> ids;
  for (size_t s = 0; s < count; ++s) ids.push_back({static_cast<std::int64_t>(s), 0});
  return ids;
}

KeyframeLoader loader() {
  return [](const KeyframeId& id) { return Keyframes::get().placed(id); };
}

std::unique_ptr<TileHierarchy> open_ok(const std::string& dir, const TilingOptions& options = {}) {
  auto h = TileHierarchy::open(dir, options);
  EXPECT_TRUE(h) << (h ? "" : h.error().message);
  return h ? std::move(*h) : nullptr;
}

void append_world_triangles(const Scene& placed, std::vector<std::array<Eigen::Vector3d, 3>>& out) {
  for (const SceneNode& node : placed.nodes)
    for (size_t t = 0; t < node.mesh.triangle_count(); ++t) {
      std::array<Eigen::Vector3d, 3> tri;
      for (int k = 0; k < 3; ++k)
        tri[k] =
            (node.to_world * node.mesh.positions[node.mesh.indices[3 * t + k]].cast<double>().homogeneous()).head<3>();
      out.push_back(tri);
    }
}

// The distance from p to the nearest of `triangles` (the closest point on each: inside it, on an edge or a corner).
double distance_to(const std::vector<std::array<Eigen::Vector3d, 3>>& triangles, const Eigen::Vector3d& p) {
  double best = INFINITY;
  for (const auto& t : triangles) {
    const Eigen::Vector3d e0 = t[1] - t[0], e1 = t[2] - t[0];
    const Eigen::Vector3d n = e0.cross(e1);
    double d = INFINITY;
    if (n.squaredNorm() > 0) {  // inside: the plane's distance, when the projection's barycentrics are all >= 0
      const Eigen::Vector3d q = p - n * (n.dot(p - t[0]) / n.squaredNorm());
      const double a = n.dot((t[1] - q).cross(t[2] - q)), b = n.dot((t[2] - q).cross(t[0] - q)),
                   c = n.dot((t[0] - q).cross(t[1] - q));
      if (a >= 0 && b >= 0 && c >= 0) d = (p - q).norm();
    }
    for (int k = 0; k < 3; ++k) {  // else an edge (or its end)
      const Eigen::Vector3d a = t[k], ab = t[(k + 1) % 3] - t[k];
      const double s = ab.squaredNorm() > 0 ? std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0) : 0.0;
      d = std::min(d, (p - (a + s * ab)).norm());
    }
    best = std::min(best, d);
  }
  return best;
}

// Every keyframe's whole surface a leaf: no supersession.
TilingOptions whole_keyframes() {
  TilingOptions o;
  o.supersede = false;
  return o;
}

// A tile's mesh in world coordinates (a leaf's node is placed by its keyframe's pose).
Mesh tile_mesh(const TileHierarchy& h, const TileRecord& r) {
  auto scene = read_glb_file(h.storage().where() + "/" + r.file());
  EXPECT_TRUE(scene) << r.file();
  if (!scene || scene->nodes.empty()) return {};
  SceneNode& node = scene->nodes.front();
  for (auto& p : node.mesh.positions) p = (node.to_world * p.cast<double>().homogeneous()).head<3>().cast<float>();
  return node.mesh;
}

std::map<TileKey, std::vector<std::uint8_t>> contents(const TileHierarchy& h) {
  std::map<TileKey, std::vector<std::uint8_t>> out;
  for (const auto& [key, r] : h.tiles()) {
    auto bytes = read_file_bytes(h.storage().where() + "/" + r.file(), size_t(1) << 30);
    EXPECT_TRUE(bytes) << r.file();
    if (bytes) out[key] = *bytes;
  }
  return out;
}

TEST(TileKeyTest, ParentsFloorAndNamesRoundTrip) {
  const TileKey k{0, -3, 5};
  EXPECT_EQ(k.parent(), (TileKey{1, -2, 2}));
  EXPECT_EQ((TileKey{0, -1, -2}).parent(), (TileKey{1, -1, -1}));
  EXPECT_EQ(leaf_key(-0.1, 3.9, 2.0), (TileKey{0, -1, 1}));
  EXPECT_EQ(parse_tile_key(k.name()), k);
  const TileKey leaf{0, -3, 5, 57};  // keyframe 57's leaf, in cell (-3, 5)
  EXPECT_EQ(leaf.name(), "0_-3_5_57");
  EXPECT_EQ(parse_tile_key(leaf.name()), leaf);
  EXPECT_EQ(leaf.parent(), (TileKey{1, -2, 2}));
  EXPECT_LT(k, leaf);  // a cell sorts before its leaves, which sort by keyframe
  for (const char* bad : {"", "0_1", "a_1_2", "0_01_2", "1_1_2_3", "0_1_2_-3", "0_1_2_03", "0_1_2_3_4", "63_0_0",
                          "-1_0_0", "0_-0_1", "0_1_99999999999999"})
    EXPECT_FALSE(parse_tile_key(bad)) << bad;
}

TEST(TileHierarchyTest, EveryTriangleIsInExactlyOneLeafAndBoxesHoldTheirContent) {
  REQUIRE_KEYFRAMES();
  const auto ids = first(12);  // three laps of four keyframes
  auto h = open_ok(test::temp_dir("tiles-leaves"), whole_keyframes());
  ASSERT_TRUE(h);
  auto stats = h->update(ids, loader());
  ASSERT_TRUE(stats) << stats.error().message;
  size_t posted = 0;
  for (const auto& id : ids) posted += Keyframes::get().placed(id)->triangle_count();
  size_t in_leaves = 0, leaves = 0;
  for (const auto& [key, r] : h->tiles()) {
    const Mesh mesh = tile_mesh(*h, r);
    EXPECT_EQ(mesh.triangle_count(), r.triangles) << key.name();
    for (const auto& p : mesh.positions) ASSERT_TRUE(r.box.contains(p.cast<double>())) << key.name();
    if (key.level == 0) {
      in_leaves += r.triangles;
      ++leaves;
    }
  }
  EXPECT_EQ(in_leaves, posted);
  EXPECT_EQ(leaves, ids.size());
  // Each keyframe is one leaf, in the cell of its surface's centroid, that shows its triangles with its own texture
  // bytes (not encoded again).
  for (const auto& id : ids) {
    auto scene = Keyframes::get().placed(id);
    const auto& leaves_of = h->keyframes().at(id.seq).leaves;
    ASSERT_EQ(leaves_of.size(), 1u) << id.seq;
    EXPECT_EQ(leaves_of.front(), keyframe_leaf(*scene, id.seq, h->options().leaf_size_m)) << id.seq;
    const Mesh leaf = tile_mesh(*h, h->tiles().at(leaves_of.front()));
    EXPECT_EQ(leaf.triangle_count(), scene->triangle_count()) << id.seq;
    EXPECT_FALSE(leaf.texture_encoded.empty()) << id.seq;
    EXPECT_EQ(leaf.texture_encoded, scene->nodes.front().mesh.texture_encoded) << id.seq;
  }
}

TEST(TileHierarchyTest, ErrorGrowsFromLeavesToRootAndInnerTilesAreSimplified) {
  REQUIRE_KEYFRAMES();
  auto h = open_ok(test::temp_dir("tiles-error"));
  ASSERT_TRUE(h);
  ASSERT_TRUE(h->update(first(12), loader()));
  size_t leaf_triangles_total = 0, top_triangles = 0;
  for (const auto& [key, r] : h->tiles()) {
    if (key.level == 0) {
      EXPECT_EQ(r.geometric_error_m, 0.0);
      leaf_triangles_total += r.triangles;
    }
    if (key.level == h->options().top_level) top_triangles += r.triangles;
    if (key.level < h->options().top_level) {
      auto parent = h->tiles().find(key.parent());
      ASSERT_NE(parent, h->tiles().end()) << key.name() << " has no parent";
      EXPECT_GE(parent->second.geometric_error_m, r.geometric_error_m) << key.name();
      EXPECT_TRUE(parent->second.box.contains(r.box)) << key.name();
    }
  }
  EXPECT_GT(top_triangles, 0u);
  EXPECT_LT(top_triangles * 8, leaf_triangles_total) << "the top tiles are not simplified";
  // The tileset says the same, in the z-up frame: the root's error covers its children's, every box nests.
  const auto tileset = make_tileset(h->tiles(), h->options().top_level, h->version(), "tiles/");
  EXPECT_EQ(tileset["asset"]["version"], "1.1");
  std::function<void(const nlohmann::json&, double)> walk = [&](const nlohmann::json& t, double parent_error) {
    EXPECT_LE(t["geometricError"].get<double>(), parent_error);
    EXPECT_EQ(t["refine"], "REPLACE");
    for (const auto& c : t.value("children", nlohmann::json::array())) walk(c, t["geometricError"].get<double>());
  };
  walk(tileset["root"], tileset["geometricError"].get<double>());
}

// A robot that returns to the same room: every keyframe lands in the same cells, so a level-1 tile is built from
// more keyframes than the update's decoded-keyframe cache keeps (16), and each keyframe is still its own leaf.
// Ten passes over the same four poses, without supersession: every pass is a leaf (and the cell holds more of them
// than the scene cache keeps); with it (the default), the last pass's keyframes cover the earlier ones whole, and the
// cell holds exactly what one pass holds.
TEST(TileHierarchyTest, ACellSeenOnManyPassesKeepsTheNewestPassOnly) {
  REQUIRE_KEYFRAMES();
  const size_t passes = 10, n = Keyframes::get().size();  // 40 keyframes, 10 on each of the 4 poses
  KeyframeLoader same_place = [n](const KeyframeId& id) {
    return Keyframes::get().placed({static_cast<std::int64_t>(static_cast<size_t>(id.seq) % n), id.rev});
  };
  const auto ids = first(passes * n);
  size_t posted = 0;
  for (const auto& id : ids) posted += same_place(id)->triangle_count();
  auto whole = open_ok(test::temp_dir("tiles-revisit-whole"), whole_keyframes());
  auto newest = open_ok(test::temp_dir("tiles-revisit"));
  auto one_pass = open_ok(test::temp_dir("tiles-revisit-one"));
  ASSERT_TRUE(whole && newest && one_pass);
  for (auto* h : {whole.get(), newest.get()}) {
    auto stats = h->update(ids, same_place);
    ASSERT_TRUE(stats) << stats.error().message;
  }
  ASSERT_TRUE(one_pass->update(first(n), same_place));
  size_t in_leaves = 0, most_children = 0;
  for (const auto& [key, r] : whole->tiles()) {
    if (key.level == 0) {
      EXPECT_EQ(tile_mesh(*whole, r).triangle_count(), r.triangles) << key.name();
      in_leaves += r.triangles;
    }
    if (key.level == 1) {
      most_children = std::max(most_children, children_of(whole->tiles(), key).size());
      EXPECT_GT(tile_mesh(*whole, r).triangle_count(), 0u) << key.name();
    }
  }
  EXPECT_GT(most_children, 16u) << "the test must put more keyframes under one tile than the cache keeps";
  EXPECT_EQ(in_leaves, posted);

  size_t leaves = 0;
  for (const auto& [key, r] : newest->tiles()) leaves += key.level == 0;
  EXPECT_LE(leaves, n);
  for (const auto& id : ids) {
    const auto& kept = newest->keyframes().at(id.seq);
    const auto& alone = one_pass->keyframes().at(id.seq % static_cast<std::int64_t>(n));
    if (static_cast<size_t>(id.seq) < (passes - 1) * n) {
      EXPECT_TRUE(kept.leaves.empty()) << "keyframe " << id.seq << " is seen again by a later pass";
      EXPECT_FALSE(kept.covered_by.empty()) << id.seq;
      continue;
    }
    ASSERT_EQ(kept.leaves.size(), alone.leaves.size()) << id.seq;
    if (kept.leaves.empty()) continue;
    EXPECT_EQ(newest->tiles().at(kept.leaves[0]).triangles, one_pass->tiles().at(alone.leaves[0]).triangles) << id.seq;
  }
}

// Newer keyframes of one lap trim the older ones where they saw the same surface: the newest is whole, the older
// ones lose triangles, and each triangle they lose lies on a newer keyframe's surface.
TEST(TileHierarchyTest, NewerKeyframesSupersedeOnlyTheSurfaceTheySawAgain) {
  REQUIRE_KEYFRAMES();
  const auto ids = first(4);
  auto h = open_ok(test::temp_dir("tiles-supersede"));
  ASSERT_TRUE(h);
  auto stats = h->update(ids, loader());
  ASSERT_TRUE(stats) << stats.error().message;
  size_t dropped = 0;
  for (const auto& id : ids) {
    auto scene = Keyframes::get().placed(id);
    ASSERT_TRUE(scene);
    const auto& e = h->keyframes().at(id.seq);
    const size_t shown = e.leaves.empty() ? 0 : tile_mesh(*h, h->tiles().at(e.leaves[0])).triangle_count();
    if (id.seq == ids.back().seq) {
      EXPECT_EQ(shown, scene->triangle_count()) << "the newest keyframe is whole";
      continue;
    }
    EXPECT_LE(shown, scene->triangle_count()) << id.seq;
    dropped += scene->triangle_count() - shown;
    // How many of its triangles lie within 10 cm of the newer keyframes' surfaces (every corner): at most those can
    // have been dropped.
    std::vector<std::array<Eigen::Vector3d, 3>> newer;
    for (const auto& n : ids)
      if (n.seq > id.seq) append_world_triangles(*Keyframes::get().placed(n), newer);
    const SceneNode& node = scene->nodes.front();
    std::vector<bool> near(node.mesh.positions.size());
    for (size_t v = 0; v < near.size(); ++v)
      near[v] =
          distance_to(newer, (node.to_world * node.mesh.positions[v].cast<double>().homogeneous()).head<3>()) <= 0.10;
    size_t near_newer = 0;
    for (size_t t = 0; t < node.mesh.triangle_count(); ++t)
      near_newer +=
          near[node.mesh.indices[3 * t]] && near[node.mesh.indices[3 * t + 1]] && near[node.mesh.indices[3 * t + 2]];
    EXPECT_LE(scene->triangle_count() - shown, near_newer) << id.seq;
  }
  EXPECT_GT(dropped, 0u);
}

TEST(TileHierarchyTest, IncrementalUpdatesGiveTheSameTilesAsOneBuild) {
  REQUIRE_KEYFRAMES();
  auto once = open_ok(test::temp_dir("tiles-once"));
  const std::string steps_dir = test::temp_dir("tiles-steps");
  auto steps = open_ok(steps_dir);
  ASSERT_TRUE(once && steps);
  ASSERT_TRUE(once->update(first(8), loader()));
  for (size_t n = 1; n <= 8; ++n) {
    // Reopened halfway: what the newer keyframes covered is not stored, and is worked out again when needed.
    if (n == 6) steps = open_ok(steps_dir);
    ASSERT_TRUE(steps);
    auto s = steps->update(first(n), loader());
    ASSERT_TRUE(s) << s.error().message;
    EXPECT_EQ(s->keyframes_changed, 1u);
    // A keyframe builds its own leaf and those of the older keyframes it trims (a leaf it covers whole goes).
    EXPECT_GE(s->leaves_built, 1u);
    EXPECT_LE(s->leaves_built, 1u + s->leaves_trimmed);
    EXPECT_EQ(s->stale, 0u);
  }
  EXPECT_EQ(steps->version(), 8u);
  EXPECT_EQ(contents(*once), contents(*steps));  // byte for byte, so every view of them is the same too
}

// The live path, on an injected clock (seconds): a step commits a new keyframe's leaf at once, its ancestors stale;
// the tileset refines through stale tiles to it; a sweep builds only tiles nothing changed under for settle_s, gives
// way after every tile, and the sweeps still end where one build does.
TEST(TileHierarchyTest, AStepShowsANewKeyframeAtOnceAndSweepsEndWhereOneBuildDoes) {
  REQUIRE_KEYFRAMES();
  auto once = open_ok(test::temp_dir("tiles-once-live"));
  auto live = open_ok(test::temp_dir("tiles-live"));
  ASSERT_TRUE(once && live);
  ASSERT_TRUE(once->update(first(8), loader()));
  const auto always = [] { return true; };  // new keyframes always wait: every sweep builds one tile
  size_t sweeps = 0;
  const double settle_s = live->options().settle_s;
  ASSERT_GT(settle_s, 0.0);
  for (size_t n = 1; n <= 8; ++n) {
    const double t = static_cast<double>(n) * settle_s;  // keyframe n at t
    auto s = live->step(first(n), loader(), t, nullptr, always);
    ASSERT_TRUE(s) << s.error().message;
    EXPECT_GE(s->leaves_built, 1u);
    EXPECT_LE(s->leaves_built, 1u + s->leaves_trimmed);
    EXPECT_EQ(s->inner_built, 0u);
    EXPECT_GT(s->stale, 0u);
    EXPECT_EQ(live->snapshot()->stale, s->stale);  // what a view reports (X-Stale-Tiles)
    EXPECT_GE(s->next_sweep_s, t);
    EXPECT_LE(s->next_sweep_s, t + settle_s);
    const TileKey leaf = live->keyframes().at(static_cast<std::int64_t>(n - 1)).leaves.at(0);
    const TileRecord& leaf_record = live->tiles().at(leaf);
    for (TileKey k = leaf.parent(); k.level <= live->options().top_level; k = k.parent()) {
      ASSERT_TRUE(live->tiles().count(k)) << k.name();
      EXPECT_TRUE(live->tiles().at(k).stale) << k.name();
      EXPECT_TRUE(live->tiles().at(k).box.contains(leaf_record.box)) << k.name();
    }
    // The tileset reaches the new leaf through content-less tiles whose error is their parent's.
    const auto tileset = make_tileset(live->tiles(), live->options().top_level, live->version(), "tiles/");
    bool found = false;
    std::function<void(const nlohmann::json&, double)> walk = [&](const nlohmann::json& t, double parent_error) {
      if (!t.contains("content")) {
        EXPECT_EQ(t["geometricError"].get<double>(), parent_error);
      }
      if (t.contains("content") && t["content"]["uri"] == "tiles/" + leaf_record.file()) found = true;
      for (const auto& c : t.value("children", nlohmann::json::array())) walk(c, t["geometricError"].get<double>());
    };
    walk(tileset["root"], tileset["geometricError"].get<double>());
    EXPECT_TRUE(found) << leaf.name() << " is not in the tileset";
    // Half the time, a sweep halfway to the next keyframe: it builds one tile at most (it gives way), and none that
    // changed at t (the new leaf's ancestors are not due before t + settle_s).
    if (n % 2 == 0) {
      auto sweep = live->step(first(n), loader(), t + 0.5 * settle_s, nullptr, always);
      ASSERT_TRUE(sweep) << sweep.error().message;
      EXPECT_EQ(sweep->leaves_built, 0u);
      EXPECT_LE(sweep->inner_built + sweep->tiles_removed, 1u);
      for (TileKey k = leaf.parent(); k.level <= live->options().top_level; k = k.parent())
        EXPECT_TRUE(live->tiles().at(k).stale) << k.name() << " was built before it settled";
      ++sweeps;
    }
  }
  for (size_t i = 0; i < 200; ++i) {
    auto sweep = live->step(first(8), loader(), 100.0 * settle_s, nullptr, always);
    ASSERT_TRUE(sweep) << sweep.error().message;
    ++sweeps;
    if (sweep->stale == 0) break;
  }
  for (const auto& [key, r] : live->tiles()) EXPECT_FALSE(r.stale) << key.name();
  EXPECT_EQ(live->snapshot()->stale, 0u);
  EXPECT_EQ(contents(*once), contents(*live)) << "after " << sweeps << " sweeps";
  auto idle = live->step(first(8), loader(), 100.0 * settle_s, nullptr, always);
  ASSERT_TRUE(idle);
  EXPECT_EQ(idle->version, live->version());  // nothing left: no commit
}

// A keyframe revised every half settle_s never lets its tiles settle; they are built anyway once stale for
// max_stale_s.
TEST(TileHierarchyTest, TilesThatKeepChangingAreBuiltOnceStaleForTheLongest) {
  REQUIRE_KEYFRAMES();
  auto live = open_ok(test::temp_dir("tiles-busy"));
  ASSERT_TRUE(live);
  const double settle_s = live->options().settle_s, max_stale_s = live->options().max_stale_s;
  ASSERT_GT(max_stale_s, 4.0 * settle_s);
  std::vector<KeyframeId> ids = first(1);
  const TileKey level1 = [&] {
    EXPECT_TRUE(live->step(ids, loader(), 0.0));
    return live->keyframes().at(0).leaves.at(0).parent();
  }();
  double built_at = -1.0;
  for (std::int64_t rev = 1; built_at < 0.0 && rev < 4 * static_cast<std::int64_t>(max_stale_s / settle_s); ++rev) {
    const double t = 0.5 * settle_s * static_cast<double>(rev);
    ids[0].rev = rev % 2;  // the surface alternates: every revision changes the leaf
    ASSERT_TRUE(live->step(ids, loader(), t));
    auto sweep = live->step(ids, loader(), t + 0.25 * settle_s);
    ASSERT_TRUE(sweep) << sweep.error().message;
    if (!live->tiles().at(level1).stale) built_at = t + 0.25 * settle_s;
  }
  EXPECT_GE(built_at, max_stale_s);
  EXPECT_LE(built_at, max_stale_s + settle_s);
}

// The sweep off the caller's thread: a tile built while a revision of its keyframe is committed under it is dropped
// (its file too) and stays stale; picked again, it commits; the end is what one build gives.
TEST(TileHierarchyTest, ABuildWhoseChildrenChangedMeanwhileIsDroppedAndPickedAgain) {
  REQUIRE_KEYFRAMES();
  auto once = open_ok(test::temp_dir("tiles-once-async"));
  auto live = open_ok(test::temp_dir("tiles-async"));
  ASSERT_TRUE(once && live);
  const std::vector<KeyframeId> revised = {{0, 1}};
  ASSERT_TRUE(once->update(revised, loader()));
  ASSERT_TRUE(live->add_leaves(first(1), loader(), 0.0));
  const double later = 10.0 * live->options().settle_s;
  EXPECT_FALSE(live->next_build(0.0)) << "nothing is due before it settles";
  auto pending = live->next_build(later);
  ASSERT_TRUE(pending);
  EXPECT_EQ(pending->key.level, 1);
  auto built = live->build_tile(*pending);
  ASSERT_TRUE(built) << built.error().message;
  const std::string file = live->storage().where() + "/" + built->file();
  EXPECT_TRUE(fs::exists(file));
  ASSERT_TRUE(live->add_leaves(revised, loader(), later));  // meanwhile: keyframe 0 revised
  const auto version = live->version();
  auto dropped = live->finish_build(*pending, std::move(built), later);
  ASSERT_TRUE(dropped) << dropped.error().message;
  EXPECT_EQ(dropped->inner_built, 0u);
  EXPECT_EQ(live->version(), version) << "a dropped build commits nothing";
  EXPECT_FALSE(fs::exists(file));
  EXPECT_TRUE(live->tiles().at(pending->key).stale);
  EXPECT_GT(dropped->next_sweep_s, later);  // changed at `later`: due once settled again
  const double t = later + 10.0 * live->options().settle_s;
  for (int i = 0; i < 20; ++i) {
    auto next = live->next_build(t);
    if (!next) break;
    auto finished = live->finish_build(*next, live->build_tile(*next), t);
    ASSERT_TRUE(finished) << finished.error().message;
    EXPECT_EQ(finished->inner_built + finished->tiles_removed, 1u);
  }
  EXPECT_EQ(live->status(t).stale, 0u);
  EXPECT_EQ(contents(*once), contents(*live));
}

// With and without supersession: a revision gives what a hierarchy made with the revision from the start has (the
// older keyframe it covered worked out again), and a keyframe no longer listed leaves the tiles.
TEST(TileHierarchyTest, ARevisionReplacesItsKeyframesSurface) {
  REQUIRE_KEYFRAMES();
  for (const TilingOptions& options : {TilingOptions{}, whole_keyframes()}) {
    SCOPED_TRACE(options.supersede ? "supersede" : "whole keyframes");
    auto revised = open_ok(test::temp_dir("tiles-revised"), options);
    auto fresh = open_ok(test::temp_dir("tiles-fresh"), options);
    ASSERT_TRUE(revised && fresh);
    ASSERT_TRUE(revised->update(first(4), loader()));
    std::vector<KeyframeId> with_revision = first(4);
    with_revision[1].rev = 1;  // seq 1 now carries another surface
    auto s = revised->update(with_revision, loader());
    ASSERT_TRUE(s) << s.error().message;
    EXPECT_EQ(s->keyframes_changed, 1u);
    EXPECT_EQ(revised->keyframes().at(1).rev, 1);
    ASSERT_TRUE(fresh->update(with_revision, loader()));
    EXPECT_EQ(contents(*revised), contents(*fresh));
    if (!options.supersede) {
      size_t leaves = 0, expected = 0;
      for (const auto& [key, r] : revised->tiles())
        if (key.level == 0) leaves += r.triangles;
      for (const auto& id : with_revision) expected += Keyframes::get().placed(id)->triangle_count();
      EXPECT_EQ(leaves, expected);
    }
    // A keyframe no longer listed leaves the tiles too, and what it covered of older ones comes back.
    auto removed = revised->update(first(3), loader());
    ASSERT_TRUE(removed);
    EXPECT_FALSE(revised->keyframes().count(3));
    auto without = open_ok(test::temp_dir("tiles-without"), options);
    ASSERT_TRUE(without && without->update(first(3), loader()));
    EXPECT_EQ(contents(*revised), contents(*without));
  }
}

// A stopped update commits nothing; reopening serves the committed version, deletes what the stopped one wrote and
// builds nothing again.
TEST(TileHierarchyTest, ReopeningServesTheCommittedVersionAndBuildsNothingAgain) {
  REQUIRE_KEYFRAMES();
  const std::string dir = test::temp_dir("tiles-reopen");
  std::map<TileKey, std::vector<std::uint8_t>> before;
  {
    auto h = open_ok(dir);
    ASSERT_TRUE(h && h->update(first(4), loader()));
    ASSERT_TRUE(h->update(first(6), loader()));
    before = contents(*h);
    // A stop during the next update (set while its new keyframes load) ends it uncommitted.
    std::atomic<bool> stop{false};
    const auto stopped = h->update(
        first(8),
        [&](const KeyframeId& id) {
          if (id.seq >= 6) stop = true;
          return Keyframes::get().placed(id);
        },
        &stop);
    ASSERT_FALSE(stopped);
    EXPECT_EQ(stopped.error().code, ErrorCode::kUnavailable) << stopped.error().message;
    EXPECT_EQ(h->version(), 2u);
    EXPECT_EQ(h->snapshot()->version, 2u);
    EXPECT_EQ(contents(*h), before);
  }
  auto h = open_ok(dir);
  ASSERT_TRUE(h);
  EXPECT_EQ(h->version(), 2u);
  EXPECT_EQ(contents(*h), before);
  auto again = h->update(first(6), loader());
  ASSERT_TRUE(again);
  EXPECT_EQ(again->keyframes_changed, 0u);
  EXPECT_EQ(h->version(), 2u);
  // Only the committed version's files remain (the previous version's are deleted on open).
  size_t files = 0;
  for (const auto& e : fs::directory_iterator(dir)) files += e.path().extension() == ".glb";
  EXPECT_EQ(files, h->tiles().size());
}

// kill -9 while an update writes: the hierarchy opened afterwards is a committed one, whole, and nothing else is left.
TEST(TileHierarchyTest, AKilledUpdateLeavesTheLastCommittedHierarchyWhole) {
  REQUIRE_KEYFRAMES();
  // How long a whole update takes here, to kill the next ones at several points inside it.
  double update_s = 0.0;
  {
    auto probe = open_ok(test::temp_dir("tiles-probe"));
    ASSERT_TRUE(probe && probe->update(first(4), loader()));
    const auto t0 = std::chrono::steady_clock::now();
    ASSERT_TRUE(probe->update(first(12), loader()));
    update_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  for (double fraction : {0.15, 0.5, 0.85}) {
    const std::string dir = test::temp_dir("tiles-kill");
    std::map<TileKey, std::vector<std::uint8_t>> committed;
    {
      auto h = open_ok(dir);
      ASSERT_TRUE(h && h->update(first(4), loader()));
      committed = contents(*h);
    }
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      auto h = TileHierarchy::open(dir, TilingOptions{});
      if (h) (void)(*h)->update(first(12), loader());
      _exit(0);
    }
    std::this_thread::sleep_for(std::chrono::duration<double>(fraction * update_s));
    kill(child, SIGKILL);
    int status = 0;
    waitpid(child, &status, 0);
    auto h = open_ok(dir);
    ASSERT_TRUE(h);
    ASSERT_TRUE(h->version() == 1u || h->version() == 2u) << h->version();
    if (h->version() == 1u) {
      EXPECT_EQ(contents(*h), committed) << "at " << fraction;
    }
    for (const auto& [key, r] : h->tiles()) EXPECT_FALSE(tile_mesh(*h, r).positions.empty()) << r.file();
    size_t files = 0;
    for (const auto& e : fs::directory_iterator(dir)) files += e.path().filename() != "hierarchy.json";
    EXPECT_EQ(files, h->tiles().size()) << "a cut update's files were left behind (at " << fraction << ")";
    // And it goes on from there.
    auto finished = h->update(first(12), loader());
    ASSERT_TRUE(finished) << finished.error().message;
    EXPECT_EQ(h->keyframes().size(), 12u);
  }
}

// A textured mesh's colour at triangle t, barycentric weights b: the texel under the interpolated UV.
// The colour of triangle t at barycentric b: its texel, or its vertex colours interpolated.
Eigen::Vector3d texel_at(const Mesh& m, size_t t, const Eigen::Vector3d& b) {
  if (m.uvs.empty() || m.texture.empty()) {
    Eigen::Vector3d rgb = Eigen::Vector3d::Zero();
    for (int k = 0; k < 3 && !m.colors.empty(); ++k) {
      const Rgb8& c = m.colors[m.indices[3 * t + k]];
      rgb += b[k] * Eigen::Vector3d(c[0], c[1], c[2]);
    }
    return rgb;
  }
  Eigen::Vector2d uv = Eigen::Vector2d::Zero();
  for (int k = 0; k < 3; ++k) uv += b[k] * m.uvs[m.indices[3 * t + k]].cast<double>();
  const int x = std::clamp(static_cast<int>(uv.x() * m.texture.width), 0, m.texture.width - 1);
  const int y = std::clamp(static_cast<int>(uv.y() * m.texture.height), 0, m.texture.height - 1);
  const std::uint8_t* px = m.texture.pixel(x, y);
  return {double(px[0]), double(px[1]), double(px[2])};
}

// A placed keyframe's mesh in world coordinates, moved by `shift` metres; `flip` reverses its triangles (the same
// surface seen from behind).
Mesh world_mesh(std::int64_t seq, const Eigen::Vector3f& shift, bool flip) {
  auto scene = Keyframes::get().placed({seq, 0});
  EXPECT_TRUE(scene);
  if (!scene || scene->nodes.empty()) return {};
  SceneNode node = scene->nodes.front();
  for (auto& p : node.mesh.positions)
    p = (node.to_world * p.cast<double>().homogeneous()).head<3>().cast<float>() + shift;
  if (flip)
    for (size_t t = 0; t < node.mesh.triangle_count(); ++t)
      std::swap(node.mesh.indices[3 * t + 1], node.mesh.indices[3 * t + 2]);
  return node.mesh;
}

// A wavy n x n grid of squares, vertex-coloured. `shared_edges`: both triangles of each square (a manifold surface);
// else only one, so that triangles meet only at corners, as pieces of overlapping keyframes do at the top of a long
// mission's hierarchy (the merged children of a level-6 tile: 13,140 pieces, 70 % of their edges open).
Mesh wavy_grid(int n, bool shared_edges) {
  Mesh m;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      m.positions.emplace_back(0.05f * i, 0.1f * std::sin(0.2f * i) * std::cos(0.3f * j), 0.05f * j);
      m.colors.push_back({static_cast<std::uint8_t>(2 * i), static_cast<std::uint8_t>(2 * j), 128});
    }
  const auto v = [&](int i, int j) { return static_cast<std::uint32_t>(j * (n + 1) + i); };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      m.indices.insert(m.indices.end(), {v(i, j), v(i, j + 1), v(i + 1, j)});
      if (shared_edges) m.indices.insert(m.indices.end(), {v(i + 1, j), v(i, j + 1), v(i + 1, j + 1)});
    }
  return m;
}

TEST(TileInnerTest, WhereEdgeCollapsesStallTheTileIsClusteredToItsTargetAndItsErrorBoundsTheSurface) {
  // Triangles that meet only at corners leave edge collapses nothing to collapse: meshopt_simplify kept 9,999 of
  // such 10,000 triangles against a target of 2,500.
  const Mesh pieces = wavy_grid(60, false);
  auto inner = build_inner({&pieces}, 0.0, SimplifyTarget{}, InnerBakeOptions{});
  ASSERT_TRUE(inner) << inner.error().message;
  const size_t target = (pieces.triangle_count() + 3) / 4;
  EXPECT_TRUE(inner->clustered);
  EXPECT_LE(inner->mesh.triangle_count(), target);
  EXPECT_GT(inner->mesh.triangle_count(), target / 4);
  // The error is a bound: no input vertex is farther from the tile's surface (measured here by brute force).
  std::vector<std::array<Eigen::Vector3d, 3>> tile;
  for (size_t t = 0; t < inner->mesh.triangle_count(); ++t) {
    std::array<Eigen::Vector3d, 3> tri;
    for (int k = 0; k < 3; ++k) tri[k] = inner->mesh.positions[inner->mesh.indices[3 * t + k]].cast<double>();
    tile.push_back(tri);
  }
  double farthest = 0.0;
  for (const auto& p : pieces.positions) farthest = std::max(farthest, distance_to(tile, p.cast<double>()));
  std::printf("%zu triangles meeting at corners -> %zu (target %zu), error %.4f m, farthest vertex %.4f m\n",
              pieces.triangle_count(), inner->mesh.triangle_count(), target, inner->simplify_error_m, farthest);
  EXPECT_GT(farthest, 0.0);
  EXPECT_GE(inner->simplify_error_m, farthest - 1e-6);
  EXPECT_LT(inner->simplify_error_m, 0.5);  // the grid is 3 m across: the clustered tile still follows it
  // A manifold surface of the same shape is simplified by edge collapses, as before.
  const Mesh surface = wavy_grid(60, true);
  auto collapsed = build_inner({&surface}, 0.0, SimplifyTarget{}, InnerBakeOptions{});
  ASSERT_TRUE(collapsed) << collapsed.error().message;
  EXPECT_FALSE(collapsed->clustered);
  EXPECT_LE(collapsed->mesh.triangle_count(), (surface.triangle_count() + 3) / 4);
}

TEST(TileInnerTest, AFewTrianglesAreKeptRatherThanSimplifiedAwayOrClusteredToAFew) {
  // What a level-4 tile of three TUM keyframes was clustered to: one triangle, twice, facing both ways. Simplified
  // toward one triangle, it collapsed to nothing, and the empty tile took its branch of the tileset (and the two
  // keyframes under it) away.
  Mesh two;
  two.positions = {{-2.0963f, 0.0428f, 2.1115f}, {-1.6352f, 1.0086f, 1.0827f},  {-2.8458f, -0.5731f, 2.7594f},
                   {-2.0963f, 0.0428f, 2.1115f}, {-2.8458f, -0.5731f, 2.7594f}, {-1.6352f, 1.0086f, 1.0827f}};
  two.indices = {0, 1, 2, 3, 4, 5};
  auto inner = build_inner({&two}, 0.0, SimplifyTarget{}, InnerBakeOptions{});
  ASSERT_TRUE(inner) << inner.error().message;
  EXPECT_GE(inner->mesh.triangle_count(), 1u);
  // 16 triangles meeting at corners: the edge collapses stall at 15 (target 4), and the clustering's grid leaves 1.
  // It is not kept: a clustering is kept only near its target.
  const Mesh pieces = wavy_grid(4, false);
  auto scattered = build_inner({&pieces}, 0.0, SimplifyTarget{}, InnerBakeOptions{});
  ASSERT_TRUE(scattered) << scattered.error().message;
  std::printf("one triangle both ways -> %zu triangles; 16 meeting at corners -> %zu (clustered %d), error %.3f m\n",
              inner->mesh.triangle_count(), scattered->mesh.triangle_count(), scattered->clustered,
              scattered->simplify_error_m);
  EXPECT_GE(scattered->mesh.triangle_count(), 5u);
}

TEST(TileInnerTest, EdgeCollapsesStopAtTheErrorLimit) {
  REQUIRE_KEYFRAMES();
  const Mesh surface = world_mesh(0, Eigen::Vector3f::Zero(), false);
  auto free = build_inner({&surface}, 0.0, SimplifyTarget{}, InnerBakeOptions{});
  ASSERT_TRUE(free) << free.error().message;
  const double limit_m = free->simplify_error_m / 4;
  auto bounded = build_inner({&surface}, 0.0, SimplifyTarget{20000, limit_m}, InnerBakeOptions{});
  ASSERT_TRUE(bounded) << bounded.error().message;
  std::printf("%zu triangles: a quarter, %zu, at %.4f m; limited to %.4f m, %zu at %.4f m\n", surface.triangle_count(),
              free->mesh.triangle_count(), free->simplify_error_m, limit_m, bounded->mesh.triangle_count(),
              bounded->simplify_error_m);
  EXPECT_LE(bounded->simplify_error_m, limit_m);
  EXPECT_GT(bounded->mesh.triangle_count(), free->mesh.triangle_count());
}

// Keyframes that saw the same place give an inner tile one layer of it, not one per keyframe: a copy of a keyframe's
// surface 1 cm behind it (depth noise) is dropped, and what dropping it moved is in the tile's error; the same surface
// seen from behind, or moved far away, is kept.
TEST(TileHierarchyTest, WhereKeyframesOverlapAnInnerTileKeepsOneLayer) {
  REQUIRE_KEYFRAMES();
  const Mesh surface = world_mesh(0, Eigen::Vector3f::Zero(), false);
  ASSERT_GT(surface.triangle_count(), 1000u);
  InnerBakeOptions options;
  options.min_layer_voxel_m = 0.05;
  // Triangles kept of the two surfaces merged, and what the weld left of one (the keyframe at 1 mm).
  size_t one = 0;
  double error_m = 0.0;
  const auto kept = [&](const Mesh& other) {
    auto inner = build_inner({&surface, &other}, 0.0, SimplifyTarget{100000}, options);
    EXPECT_TRUE(inner) << (inner ? "" : inner.error().message);
    if (!inner) return size_t{0};
    one = inner->merged_triangles / 2;
    error_m = inner->layer_error_m;
    return inner->kept_triangles;
  };
  const size_t behind = kept(world_mesh(0, Eigen::Vector3f(0.0f, 0.0f, 0.01f), false));
  std::printf("a copy 1 cm behind: %zu of %zu triangles kept, layer error %.4f m\n", behind, 2 * one, error_m);
  EXPECT_GE(behind, one);
  EXPECT_LE(behind, one + one / 20) << "the copy is mostly kept";
  EXPECT_GT(error_m, 0.0);
  EXPECT_LE(error_m, 0.01 + 0.002) << "each dropped triangle has its copy 1 cm away (welded on a 1 mm grid)";

  const size_t flipped = kept(world_mesh(0, Eigen::Vector3f::Zero(), true));
  std::printf("the same surface from behind: %zu of %zu triangles kept, layer error %.4f m\n", flipped, 2 * one,
              error_m);
  // Where the depth mesh folds (silhouettes), triangles of either winding face every way: a few are covered.
  EXPECT_GE(flipped, 2 * one - one / 5) << "the back of a surface is another surface";
  EXPECT_LE(error_m, 0.002) << "what was dropped lies on the kept surface";

  const size_t far = kept(world_mesh(0, Eigen::Vector3f(1.0f, 1.0f, 1.0f), false));
  std::printf("a copy 1.7 m away: %zu of %zu triangles kept\n", far, 2 * one);
  EXPECT_GE(far, 2 * one - one / 50) << "a surface elsewhere is kept";
}

// PSNR (dB) of a level-1 tile's colours against its leaves': at every leaf triangle's centroid, the leaf's texel
// against the tile's texel where the centroid projects along the nearest tile triangle's normal (the triangle whose
// plane is nearest among those the projection falls in; centroids that fall in none are skipped).
double inner_psnr(const Mesh& inner, const std::vector<Mesh>& leaves, size_t* compared) {
  double sq = 0.0;
  *compared = 0;
  for (const Mesh& leaf : leaves)
    for (size_t t = 0; t < leaf.triangle_count(); ++t) {
      const Eigen::Vector3d third(1.0 / 3, 1.0 / 3, 1.0 / 3);
      Eigen::Vector3d c = Eigen::Vector3d::Zero();
      for (int k = 0; k < 3; ++k) c += leaf.positions[leaf.indices[3 * t + k]].cast<double>() / 3.0;
      double best = INFINITY;
      Eigen::Vector3d best_colour = Eigen::Vector3d::Zero();
      for (size_t u = 0; u < inner.triangle_count(); ++u) {
        Eigen::Matrix3d v;
        for (int k = 0; k < 3; ++k) v.col(k) = inner.positions[inner.indices[3 * u + k]].cast<double>();
        const Eigen::Vector3d n = (v.col(1) - v.col(0)).cross(v.col(2) - v.col(0));
        if (n.norm() < 1e-12) continue;
        const double d = std::abs(n.normalized().dot(c - v.col(0)));
        if (d >= best) continue;
        const Eigen::Vector3d p = c - n.normalized() * n.normalized().dot(c - v.col(0));
        Eigen::Matrix<double, 4, 3> A;
        A << v, Eigen::RowVector3d::Ones();
        Eigen::Vector4d rhs;
        rhs << p, 1.0;
        const Eigen::Vector3d b = A.colPivHouseholderQr().solve(rhs);
        if (b.minCoeff() < -1e-6) continue;
        best = d;
        best_colour = texel_at(inner, u, b);
      }
      if (!std::isfinite(best)) continue;
      sq += (best_colour - texel_at(leaf, t, third)).squaredNorm() / 3.0;
      ++*compared;
    }
  return *compared ? 10.0 * std::log10(255.0 * 255.0 / (sq / static_cast<double>(*compared))) : 0.0;
}

// Every tile is a GLB that the Khronos validator accepts, in the compact wire format (quantized, meshopt-compressed)
// with a JPEG texture; the tiles' bytes against the keyframes' bytes posted, printed per level.
TEST(TileHierarchyTest, EveryTileIsAValidCompactGlbAndStorageIsMeasured) {
  REQUIRE_KEYFRAMES();
  for (size_t count : {4u, 12u}) {
    auto h = open_ok(test::temp_dir("tiles-valid"));
    ASSERT_TRUE(h);
    const auto ids = first(count);
    ASSERT_TRUE(h->update(ids, loader()));
    size_t posted = 0;
    for (const auto& id : ids) posted += Keyframes::get().glb_bytes[static_cast<size_t>(id.seq) % 4];
    std::map<int, std::array<double, 5>> levels;  // tiles, triangles, bytes, texture bytes, largest error
    for (const auto& [key, r] : h->tiles()) {
      const std::string path = h->storage().where() + "/" + r.file();
      EXPECT_GLTF_VALID(path);
      auto bytes = read_file_bytes(path, size_t(1) << 30);
      ASSERT_TRUE(bytes);
      auto chunks = glb::parse_glb(bytes->data(), bytes->size());
      ASSERT_TRUE(chunks) << r.file();
      const auto doc = nlohmann::json::parse(chunks->json, nullptr, false);
      ASSERT_FALSE(doc.is_discarded()) << r.file();
      const auto used = doc.value("extensionsUsed", nlohmann::json::array());
      EXPECT_NE(std::find(used.begin(), used.end(), "KHR_draco_mesh_compression"), used.end()) << r.file();
      // Leaves are textured; inner tiles may be vertex-coloured (InnerBakeOptions::min_leg_texels).
      const auto images = doc.value("images", nlohmann::json::array());
      const auto attributes = doc["meshes"][0]["primitives"][0]["attributes"];
      if (key.level == 0 || !attributes.contains("COLOR_0")) {
        ASSERT_EQ(images.size(), 1u) << r.file() << " is neither textured nor coloured";
        EXPECT_EQ(images[0]["mimeType"], "image/jpeg") << r.file();
      }
      auto& l = levels[key.level];
      l[0] += 1, l[1] += r.triangles, l[2] += r.bytes;
      if (!images.empty())
        l[3] += doc["bufferViews"][images[0]["bufferView"].get<size_t>()]["byteLength"].get<double>();
      l[4] = std::max(l[4], r.geometric_error_m);
    }
    for (const auto& [key, r] : h->tiles()) {
      if (key.level != 1) continue;
      std::vector<Mesh> leaves;
      for (const auto& [child, cr] : h->tiles())
        if (child.level == 0 && child.parent() == key) leaves.push_back(tile_mesh(*h, cr));
      size_t compared = 0;
      const double psnr = inner_psnr(tile_mesh(*h, r), leaves, &compared);
      std::printf("%s: %.1f dB against its leaves at %zu leaf centroids\n", key.name().c_str(), psnr, compared);
      EXPECT_GT(psnr, 16.0) << key.name();  // 18.1-20.3 dB; at 16 texels per error-metre 21.9 dB
    }
    const double tiles_bytes = static_cast<double>(h->snapshot()->bytes);
    std::printf("%zu keyframes, %zu B posted; tiles %.0f B = %.2fx\n", count, posted, tiles_bytes,
                tiles_bytes / static_cast<double>(posted));
    std::printf("level  tiles  triangles      bytes  texture B  max error m\n");
    for (const auto& [level, l] : levels)
      std::printf("%5d %6.0f %10.0f %10.0f %10.0f %12.4f\n", level, l[0], l[1], l[2], l[3], l[4]);
  }
}

// Two writers of one storage (replicas sharing a database; here one folder's storage shared by two hierarchies): the
// one that commits second is refused, is superseded, leaves no file of its own behind, and the storage keeps the
// first one's hierarchy, which a hierarchy opened again serves and goes on from.
TEST(TileHierarchyTest, AWriterThatCommitsSecondIsSupersededAndLeavesTheFirstOnesHierarchy) {
  REQUIRE_KEYFRAMES();
  const std::string dir = test::temp_dir("tiles-two-writers");
  auto storage = directory_tile_storage(dir);
  ASSERT_TRUE(storage) << storage.error().message;
  const std::shared_ptr<TileStorage> shared = std::move(*storage);
  auto first_writer = TileHierarchy::open(shared, TilingOptions{});
  auto second_writer = TileHierarchy::open(shared, TilingOptions{});
  ASSERT_TRUE(first_writer && second_writer);
  ASSERT_TRUE((*first_writer)->update(first(2), loader()));
  const auto committed = contents(**first_writer);
  auto late = (*second_writer)->update(first(3), loader());
  ASSERT_FALSE(late);
  EXPECT_TRUE((*second_writer)->superseded()) << late.error().message;
  EXPECT_EQ((*second_writer)->version(), 0u);
  size_t files = 0;
  for (const auto& e : fs::directory_iterator(dir)) files += e.path().extension() == ".glb";
  EXPECT_EQ(files, (*first_writer)->tiles().size()) << "the refused update's files are deleted";

  auto reopened = TileHierarchy::open(shared, TilingOptions{});
  ASSERT_TRUE(reopened);
  EXPECT_EQ((*reopened)->version(), (*first_writer)->version());
  EXPECT_EQ(contents(**reopened), committed);
  auto next = (*reopened)->update(first(3), loader());
  ASSERT_TRUE(next) << next.error().message;
  EXPECT_EQ(next->keyframes_changed, 1u);
  EXPECT_GT((*reopened)->version(), (*first_writer)->version());
}

}  // namespace
}  // namespace rgbdcast::tiles
