// The view's tile selection (tiles/tile_selection.h) on a hand-made hierarchy whose answers follow from its
// definition: a row of leaves under one inner tile, cameras near, far, and looking away.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "tiles/tile_selection.h"

namespace rgbdcast::tiles {
namespace {

// Leaves (level 0) of 2 m along x at z in [0, 2], y in [-1, 0]; parents up to `top`, each with error `inner_error_m`
// times its level. Floor division keys, as TileKey::parent makes them.
std::map<TileKey, TileRecord> row_of_leaves(int leaves, int top, double inner_error_m) {
  std::map<TileKey, TileRecord> records;
  for (int i = 0; i < leaves; ++i) {
    TileRecord r;
    r.key = {0, i, 0};
    r.box = Eigen::AlignedBox3d(Eigen::Vector3d(2.0 * i, -1.0, 0.0), Eigen::Vector3d(2.0 * i + 2.0, 0.0, 2.0));
    r.triangles = 100;
    r.bytes = 1000;
    records[r.key] = r;
    for (TileKey k = r.key.parent(); k.level <= top; k = k.parent()) {
      TileRecord& p = records[k];
      p.key = k;
      p.box.extend(r.box);
      p.geometric_error_m = inner_error_m * k.level;
      p.triangles = 10;
      p.bytes = 100;
    }
  }
  return records;
}

// Looking along +z at the row from `back` metres in front of its centre line x = centre_x.
ViewCamera camera_at(double centre_x, double back) {
  auto c = ViewCamera::look_at(Eigen::Vector3d(centre_x, -0.5, -back), Eigen::Vector3d(centre_x, -0.5, 1.0),
                               Eigen::Vector3d(0, -1, 0), 60.0, 640, 480);
  EXPECT_TRUE(c.ok());
  c->far_m = 1000.0;
  return *c;
}

std::set<TileKey> keys(const TileSelection& s) {
  std::set<TileKey> out;
  for (const TileRecord* r : s.tiles) out.insert(r->key);
  return out;
}

TEST(TileSelection, ErrorDecidesTheLevelAndZeroMeansLeaves) {
  const auto records = row_of_leaves(8, 3, 0.05);  // 16 m of floor; top tile at level 3, error 0.15 m
  // Far away (500 m): the top tile's error is 0.15 * fy / 500, well under 1 px: one tile, the top.
  const ViewCamera far = camera_at(8.0, 500.0);
  const TileSelection top = select_tiles(records, 3, far, 1.0);
  ASSERT_EQ(top.tiles.size(), 1u);
  EXPECT_EQ(top.tiles.front()->key, (TileKey{3, 0, 0}));
  EXPECT_EQ(top.triangles, 10u);
  // max-error 0 is full detail: every visible leaf, whatever the distance.
  const TileSelection full = select_tiles(records, 3, far, 0.0);
  EXPECT_EQ(full.tiles.size(), 8u);
  for (const TileRecord* r : full.tiles) EXPECT_EQ(r->key.level, 0);
  EXPECT_EQ(full.triangles, 800u);
  // Nearer, the coarse tiles' projected error grows past 1 px and they refine.
  const TileSelection near = select_tiles(records, 3, camera_at(8.0, 20.0), 1.0);
  EXPECT_GT(near.tiles.size(), 1u);
  // A larger tolerance never draws more triangles, at any distance.
  for (double back : {5.0, 20.0, 80.0, 300.0}) {
    size_t previous = SIZE_MAX;
    for (double px : {0.0, 0.5, 1.0, 4.0, 16.0, 64.0}) {
      const TileSelection s = select_tiles(records, 3, camera_at(8.0, back), px);
      EXPECT_LE(s.triangles, previous) << back << " m, " << px << " px";
      previous = s.triangles;
    }
  }
}

TEST(TileSelection, AViewOverTheRendererBudgetIsCoarsenedUntilItFits) {
  auto records = row_of_leaves(8, 3, 0.05);
  for (auto& [key, r] : records) r.render_bytes = key.level == 0 ? 4000 : 1000;
  const ViewCamera near = camera_at(8.0, 5.0);
  const TileSelection full = select_tiles(records, 3, near, 1.0);
  ASSERT_GT(full.render_bytes, 8000u);  // near: mostly leaves
  double used = -1.0;
  // A budget the selection fits: the error asked for, the same tiles.
  const TileSelection same = select_tiles_to_fit(records, 3, near, 1.0, full.render_bytes, 1000.0, &used);
  EXPECT_EQ(used, 1.0);
  EXPECT_EQ(keys(same), keys(full));
  // No budget: the same.
  EXPECT_EQ(keys(select_tiles_to_fit(records, 3, near, 0.0, 0, 1000.0, &used)),
            keys(select_tiles(records, 3, near, 0.0)));
  EXPECT_EQ(used, 0.0);
  // Smaller budgets: a coarser error, a power of two times 1 px, under the budget, and the smallest such error (half
  // of it does not fit).
  for (size_t budget : {8000u, 4000u, 2000u, 1000u}) {
    const TileSelection fit = select_tiles_to_fit(records, 3, near, 1.0, budget, 1000.0, &used);
    EXPECT_LE(fit.render_bytes, budget) << budget;
    EXPECT_GT(used, 1.0) << budget;
    EXPECT_EQ(std::exp2(std::round(std::log2(used))), used) << budget;
    EXPECT_GT(select_tiles(records, 3, near, used / 2.0).render_bytes, budget) << budget;
    EXPECT_EQ(keys(fit), keys(select_tiles(records, 3, near, used))) << budget;
  }
  // A budget below the top tile: the limit, and what it selects.
  const TileSelection floor = select_tiles_to_fit(records, 3, near, 1.0, 10, 1000.0, &used);
  EXPECT_EQ(used, 1000.0);
  EXPECT_EQ(keys(floor), keys(select_tiles(records, 3, near, 1000.0)));
}

// The contract of select_tiles_within, checked on a selection: within the budget (unless the top tiles alone are
// over it), REPLACE (no drawn tile under another), nothing stale or culled drawn, and no drawn tile left coarse that
// was above the error and whose visible children would have fitted in place of it.
void expect_budget_contract(const std::map<TileKey, TileRecord>& records, const ViewCamera& camera, double max_px,
                            size_t budget, const TileSelection& s) {
  const std::set<TileKey> drawn = keys(s);
  std::uint64_t total = 0;
  for (const TileRecord* r : s.tiles) total += r->render_bytes;
  EXPECT_EQ(total, s.render_bytes);
  EXPECT_LE(s.render_bytes, budget);
  for (const TileRecord* r : s.tiles) {
    EXPECT_FALSE(r->stale && r->key.level > 0) << r->key.name();
    EXPECT_TRUE(box_in_frustum(r->box, camera)) << r->key.name();
    for (TileKey a = r->key.parent(); records.count(a); a = a.parent()) EXPECT_FALSE(drawn.count(a)) << r->key.name();
    const auto children = children_of(records, r->key);
    if (r->key.level == 0 || children.empty()) continue;
    const double d = distance_to_box(r->box, camera);
    const double sse = d > 0.0 ? r->geometric_error_m * camera.fy / d : INFINITY;
    if (sse <= max_px) continue;
    std::uint64_t children_bytes = 0;
    for (const TileRecord* c : children)
      if (box_in_frustum(c->box, camera)) children_bytes += c->render_bytes;
    EXPECT_GT(s.render_bytes - r->render_bytes + children_bytes, budget) << r->key.name() << " could have refined";
  }
}

TEST(TileSelection, ACameraInsideTheTilesIsBoundedByRefiningTheLargestErrorFirst) {
  auto records = row_of_leaves(8, 3, 0.05);
  for (auto& [key, r] : records) r.render_bytes = key.level == 0 ? 4000 : 1000;
  // Standing inside leaf 4's box (and its ancestors'): their distance is 0, so they refine at any error, and no
  // uniform error brings the view under a budget below two leaves.
  auto inside = ViewCamera::look_at(Eigen::Vector3d(9.0, -0.5, 0.5), Eigen::Vector3d(9.0, -0.5, 5.0),
                                    Eigen::Vector3d(0, -1, 0), 60.0, 640, 480);
  ASSERT_TRUE(inside.ok());
  inside->far_m = 1000.0;
  const TileSelection at_limit = select_tiles(records, 3, *inside, 1000.0);
  EXPECT_TRUE(keys(at_limit).count(TileKey{0, 4, 0}));
  for (size_t budget : {1000u, 2500u, 4500u, 7000u}) {
    ASSERT_GT(at_limit.render_bytes, budget);
    double used = -1.0;
    const TileSelection fit = select_tiles_to_fit(records, 3, *inside, 1.0, budget, 1000.0, &used);
    EXPECT_EQ(used, 1000.0) << budget;
    EXPECT_EQ(keys(fit), keys(select_tiles_within(records, 3, *inside, 1.0, budget))) << budget;
    expect_budget_contract(records, *inside, 1.0, budget, fit);
  }
  // A budget no refinement exceeds: what the error alone selects.
  EXPECT_EQ(keys(select_tiles_within(records, 3, *inside, 1.0, SIZE_MAX)),
            keys(select_tiles(records, 3, *inside, 1.0)));
  EXPECT_EQ(keys(select_tiles_within(records, 3, camera_at(8.0, 20.0), 1.0, SIZE_MAX)),
            keys(select_tiles(records, 3, camera_at(8.0, 20.0), 1.0)));
  // A budget below the top tile: the top tile, over the budget (nothing coarser exists).
  const TileSelection top = select_tiles_within(records, 3, *inside, 1.0, 10);
  ASSERT_EQ(top.tiles.size(), 1u);
  EXPECT_EQ(top.tiles.front()->key, (TileKey{3, 0, 0}));
  // Stale tiles are never drawn: the top and a level-2 tile stale, their fresh descendants stand in, within budget.
  records[TileKey{3, 0, 0}].stale = true;
  records[TileKey{2, 1, 0}].stale = true;
  const TileSelection stale = select_tiles_within(records, 3, *inside, 1.0, 4500);
  EXPECT_FALSE(keys(stale).count(TileKey{3, 0, 0}));
  EXPECT_FALSE(keys(stale).count(TileKey{2, 1, 0}));
  EXPECT_FALSE(stale.tiles.empty());
  expect_budget_contract(records, *inside, 1.0, 4500, stale);
}

TEST(TileSelection, TheSelectionCoversTheViewOnceAndCullsWhatIsBehind) {
  const auto records = row_of_leaves(8, 3, 0.05);
  for (double px : {0.0, 1.0, 8.0}) {
    const TileSelection s = select_tiles(records, 3, camera_at(8.0, 12.0), px);
    // REPLACE: no drawn tile is an ancestor of another drawn tile.
    const std::set<TileKey> drawn = keys(s);
    for (const TileKey& k : drawn)
      for (TileKey a = k.parent(); a.level <= 3; a = a.parent()) EXPECT_FALSE(drawn.count(a)) << k.name();
    // Every leaf is covered by exactly one drawn tile (the whole row is in view from 12 m back at 60 degrees).
    for (int i = 0; i < 8; ++i) {
      int covering = 0;
      for (TileKey a{0, i, 0}; a.level <= 3; a = a.parent()) covering += static_cast<int>(drawn.count(a));
      EXPECT_EQ(covering, 1) << "leaf " << i << " at " << px << " px";
    }
  }
  // Turned around, looking along -z away from the row: nothing is drawn.
  auto away = ViewCamera::look_at(Eigen::Vector3d(8.0, -0.5, -3.0), Eigen::Vector3d(8.0, -0.5, -10.0),
                                  Eigen::Vector3d(0, -1, 0), 60.0, 640, 480);
  ASSERT_TRUE(away.ok());
  const TileSelection none = select_tiles(records, 3, *away, 0.0);
  EXPECT_TRUE(none.tiles.empty());
  EXPECT_GE(none.culled, 1u);
  // Looking at the left end from close by: the leaves at the right end are outside the frustum.
  const TileSelection left = select_tiles(records, 3, camera_at(1.0, 1.0), 0.0);
  EXPECT_FALSE(keys(left).count(TileKey{0, 7, 0}));
  EXPECT_TRUE(keys(left).count(TileKey{0, 0, 0}));
}

TEST(TileSelection, BoxTestsAgreeWithGeometry) {
  const ViewCamera c = camera_at(0.0, 10.0);  // at (0, -0.5, -10) looking along +z
  EXPECT_TRUE(box_in_frustum(Eigen::AlignedBox3d(Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(1, 1, 1)), c));
  EXPECT_FALSE(box_in_frustum(Eigen::AlignedBox3d(Eigen::Vector3d(-1, -1, -30), Eigen::Vector3d(1, 1, -20)), c));
  EXPECT_FALSE(box_in_frustum(Eigen::AlignedBox3d(Eigen::Vector3d(50, -1, -1), Eigen::Vector3d(60, 1, 1)), c));
  EXPECT_FALSE(box_in_frustum(Eigen::AlignedBox3d(), c));  // empty
  EXPECT_DOUBLE_EQ(distance_to_box(Eigen::AlignedBox3d(Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(1, 1, 1)), c), 9.0);
  EXPECT_DOUBLE_EQ(distance_to_box(Eigen::AlignedBox3d(Eigen::Vector3d(-1, -1, -11), Eigen::Vector3d(1, 1, 1)), c),
                   0.0);
}

}  // namespace
}  // namespace rgbdcast::tiles
