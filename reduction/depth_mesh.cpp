// triangulate (realtime preset): the RTIN over the depth image. See depth_mesh.h for the model.
//
// Layout. The image is covered by tiles of S = tile_px pixels (the last row/column of tiles runs past the image; those
// grid points are invalid). Grid points are pixel centres, shared by neighbouring tiles. Inside a tile the triangles
// form an implicit binary tree (heap order): ids 2 and 3 are the two halves of the tile, the children of id are 2 id
// (left) and 2 id + 1 (right); triangle (a, b, c) has its hypotenuse a-b and its right angle at c, and splits at the
// hypotenuse's midpoint m into (c, a, m) and (b, c, m). Leaves have legs of one pixel (ids 2 S^2 .. 4 S^2 - 1).
//
// Errors. Each grid point of a tile is given to exactly one leaf; a triangle's pixel moments are its two children's
// sums. Its error is the RMS distance (inverse depth, in sigma units) of its valid pixels from the plane through its
// vertices, or infinite when it cannot stand for its pixels: an invalid vertex, more holes than allowed, an edge that
// jumps in depth, or affine texturing off by more than allowed. A triangle reaching across a discontinuity holds
// pixels of both surfaces, whose residuals are tens of sigma: it splits until it holds one. As in Martini's RTIN
// the error goes to the hypotenuse midpoint, maxed with the children's midpoints: a triangle and its hypotenuse
// neighbour share that point, so they split together and the mesh has no T-junction. Levels are processed
// finest-first over all tiles, so a midpoint on a tile border holds both tiles' errors before any parent reads it.
#include "reduction/depth_mesh.h"
#include "reduction/mesh_edges.h"
#include "reduction/openmp_threads.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>

#include "base/worker_threads.h"

namespace rgbdcast {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

bool is_power_of_two(int v) { return v > 0 && (v & (v - 1)) == 0; }

// A triangle id's level in the tree: the halves of a tile (ids 2, 3) are level 1.
int level_of(int id) { return 31 - __builtin_clz(static_cast<unsigned>(id)); }

// One row of unit cells between grid rows r0 and r1: a cell is smooth (1) when its four points are valid and each of
// its six pairs is within a ratio `step` of each other (branch-free, so that it vectorises).
void smooth_cells(const float* __restrict r0, const float* __restrict r1, int n, float step,
                  std::uint8_t* __restrict out) {
  auto ok = [step](float a, float b) { return (a > 0.f) & (b > 0.f) & (std::max(a, b) <= std::min(a, b) * step); };
  for (int x = 0; x < n; ++x)
    out[x] = ok(r0[x], r0[x + 1]) & ok(r1[x], r1[x + 1]) & ok(r0[x], r1[x]) & ok(r0[x + 1], r1[x + 1]) &
             ok(r0[x], r1[x + 1]) & ok(r0[x + 1], r1[x]);
}
}  // namespace

Status DepthMeshParams::validate() const {
  auto finite_pos = [](double v) { return std::isfinite(v) && v > 0; };
  if (!(std::isfinite(tolerance_factor) && tolerance_factor >= 0 && tolerance_factor <= 1e6))
    return make_error(ErrorCode::kInvalidArgument, "mesh tolerance factor must be between 0 and 1e6");
  if (!finite_pos(noise_m_per_m2) || noise_m_per_m2 > 1)
    return make_error(ErrorCode::kInvalidArgument, "depth noise must be > 0 and at most 1 (sigma = noise * z^2)");
  if (!finite_pos(jump_relative) || jump_relative >= 10)
    return make_error(ErrorCode::kInvalidArgument, "depth jump must be between 0 and 10 (relative)");
  if (!(std::isfinite(max_hole_fraction) && max_hole_fraction >= 0 && max_hole_fraction <= 1))
    return make_error(ErrorCode::kInvalidArgument, "hole fraction must be 0..1");
  if (!(std::isfinite(texture_deviation_px) && texture_deviation_px >= 0))
    return make_error(ErrorCode::kInvalidArgument, "texture deviation must be >= 0 pixels (0 = off)");
  if (!is_power_of_two(tile_px) || tile_px < 2 || tile_px > 128)
    return make_error(ErrorCode::kInvalidArgument, "tile size must be a power of two, 2..128");
  if (!(std::isfinite(boundary_px_per_sigma) && boundary_px_per_sigma > 0))
    return make_error(ErrorCode::kInvalidArgument, "boundary pixels per sigma must be > 0");
  if (!(std::isfinite(boundary_max_lost_px) && boundary_max_lost_px >= 0))
    return make_error(ErrorCode::kInvalidArgument, "boundary pixels lost must be >= 0");
  if (!(std::isfinite(simplify_px) && simplify_px >= 0 && simplify_px <= 64))
    return make_error(ErrorCode::kInvalidArgument, "simplification error must be 0..64 pixels (0 = off)");
  if (!(std::isfinite(fit_min_leg_px) && fit_min_leg_px >= 0 && fit_min_leg_px <= 128))
    return make_error(ErrorCode::kInvalidArgument, "fit minimum leg must be 0..128 pixels");
  if (!(std::isfinite(boundary_push_px) && boundary_push_px >= 0 && boundary_push_px <= 2))
    return make_error(ErrorCode::kInvalidArgument, "boundary push must be 0..2 pixels");
  return ok_status();
}

// The implicit tree of one tile size: vertex coordinates of every triangle and the leaf that owns each grid point.
struct RtinTable {
  int S = 0;
  std::vector<std::int16_t> ax, ay, bx, by, cx, cy;  // indexed by id, 2 .. 4 S^2 - 1
  std::vector<std::int32_t> leaf_of_point;           // S * S
  std::vector<std::int32_t> point_of_leaf;           // the inverse: y * S + x, or -1 (by id - first_leaf)
  std::vector<std::int16_t> point_x, point_y;        // the same point's x and y (-1 with it), so that a walk over
                                                     // the leaves needs no division by S
  std::vector<std::uint16_t> points_of;              // grid points each internal triangle owns (by id)
  int first_leaf() const { return 2 * S * S; }
  int end() const { return 4 * S * S; }

  explicit RtinTable(int s) : S(s) {
    const int n = 4 * S * S;
    for (auto* v : {&ax, &ay, &bx, &by, &cx, &cy}) v->assign(n, 0);
    // id 2: hypotenuse (S,S)-(0,0), right angle (0,S); id 3: (0,0)-(S,S), right angle (S,0).
    ax[2] = S, ay[2] = S, bx[2] = 0, by[2] = 0, cx[2] = 0, cy[2] = S;
    ax[3] = 0, ay[3] = 0, bx[3] = S, by[3] = S, cx[3] = S, cy[3] = 0;
    for (int id = 2; id < first_leaf(); ++id) {
      const int mx = (ax[id] + bx[id]) / 2, my = (ay[id] + by[id]) / 2;
      const int l = 2 * id, r = 2 * id + 1;
      ax[l] = cx[id], ay[l] = cy[id], bx[l] = ax[id], by[l] = ay[id], cx[l] = mx, cy[l] = my;
      ax[r] = bx[id], ay[r] = by[id], bx[r] = cx[id], by[r] = cy[id], cx[r] = mx, cy[r] = my;
    }
    // Each grid point (x, y), 0 <= x, y < S, goes to the first leaf inside the unit square to its lower right that
    // has it as a vertex.
    leaf_of_point.assign(static_cast<size_t>(S) * S, -1);
    for (int id = first_leaf(); id < end(); ++id) {
      const int x0 = std::min({ax[id], bx[id], cx[id]}), y0 = std::min({ay[id], by[id], cy[id]});
      if (x0 >= S || y0 >= S) continue;
      const bool has =
          (ax[id] == x0 && ay[id] == y0) || (bx[id] == x0 && by[id] == y0) || (cx[id] == x0 && cy[id] == y0);
      auto& slot = leaf_of_point[static_cast<size_t>(y0) * S + x0];
      if (has && slot < 0) slot = id;
    }
    point_of_leaf.assign(static_cast<size_t>(end() - first_leaf()), -1);
    for (int p = 0; p < S * S; ++p)
      if (leaf_of_point[p] >= 0) point_of_leaf[leaf_of_point[p] - first_leaf()] = p;
    point_x.assign(point_of_leaf.size(), -1);
    point_y.assign(point_of_leaf.size(), -1);
    for (size_t i = 0; i < point_of_leaf.size(); ++i)
      if (point_of_leaf[i] >= 0)
        point_x[i] = static_cast<std::int16_t>(point_of_leaf[i] % S),
        point_y[i] = static_cast<std::int16_t>(point_of_leaf[i] / S);
    points_of.assign(static_cast<size_t>(first_leaf()), 0);
    for (int id = first_leaf() - 1; id >= 2; --id)
      points_of[id] = id >= first_leaf() / 2 ? (point_of_leaf[2 * id - first_leaf()] >= 0) +
                                                   (point_of_leaf[2 * id + 1 - first_leaf()] >= 0)
                                             : points_of[2 * id] + points_of[2 * id + 1];
  }
};

namespace {

std::shared_ptr<const RtinTable> table_for(int S) {
  // Tables are small (4 S^2 entries) and cheap next to a frame; each hierarchy keeps its own.
  return std::make_shared<const RtinTable>(S);
}

// Pixel moments of a set of valid pixels (tile-local u, v; w = 1/z), plus counts.
struct Moments {
  double n = 0, su = 0, sv = 0, sw = 0, suu = 0, suv = 0, svv = 0, suw = 0, svw = 0, sww = 0;
  void add(const Moments& o) {
    n += o.n, su += o.su, sv += o.sv, sw += o.sw, suu += o.suu, suv += o.suv, svv += o.svv, suw += o.suw, svw += o.svw,
        sww += o.sww;
  }
};

// Affine texture interpolation against the projective mapping: the largest deviation (pixels) at the edge midpoints
// and the centroid, from the vertices' pixels p_i, depths z_i and edge lengths (the true image point of barycentre b
// is sum b_i z_i p_i / sum b_i z_i). Compares against `limit` without square roots.
// The largest texture deviation (pixels) a triangle with these edge lengths can have when the depths at the ends of
// edge e are within a ratio r[e] of each other: an edge of length L deviates at most L (r - 1) / (r + 1) / 2 at its
// midpoint, and the centroid at most 2 L_max (R / (R + 2) - 1/3) for depths within R (the largest r) of each other.
double texture_deviation_bound(const float len[3], const double r[3]) {
  double edge = 0, R = 1;
  for (int e = 0; e < 3; ++e) {
    edge = std::max(edge, len[e] * (r[e] - 1) / (r[e] + 1) / 2);
    R = std::max(R, r[e]);
  }
  return std::max(edge, 2 * len[0] * (R / (R + 2) - 1.0 / 3));
}

bool texture_deviates(const double px[3], const double py[3], const double z[3], const float len[3], double limit) {
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3;
    if (len[i] * std::abs(z[i] - z[j]) > limit * 2 * (z[i] + z[j])) return true;
  }
  const double zs = z[0] + z[1] + z[2];
  const double ux = (z[0] * px[0] + z[1] * px[1] + z[2] * px[2]) / zs - (px[0] + px[1] + px[2]) / 3;
  const double uy = (z[0] * py[0] + z[1] * py[1] + z[2] * py[2]) / zs - (py[0] + py[1] + py[2]) / 3;
  return ux * ux + uy * uy > limit * limit;
}

}  // namespace

// The largest depth ratio of an 8-neighbour step inside a smooth region (see make_depth_mesh_layout).
constexpr float kSmoothStep = 1.06f;

// The tables a build needs that depend only on the image's size and the parameters, not on its depth.
struct DepthMeshLayout {
  int width = 0, height = 0;
  double jump_relative = 0, texture_deviation_px = 0, fit_min_leg_px = 0;  // the parameters they depend on
  std::shared_ptr<const RtinTable> table;
  int S = 0, tiles_x = 0, tiles_y = 0, grid_w = 0, grid_h = 0, first_leaf = 0, end = 0, levels = 0;
  // Per level of the tree (all its triangles are congruent): each edge's length (0: the hypotenuse a-b, then b-c,
  // c-a) and the largest depth ratio it may span (jump_relative per pixel of its length).
  std::vector<std::array<float, 3>> level_len, level_ratio;
  // Levels whose triangles can deviate in texture by more than the limit once no edge jumps (else the test is
  // skipped; texture_deviation_bound).
  std::vector<std::uint8_t> level_texture_check;
  std::vector<std::array<std::int32_t, 3>> vertex_offset;  // each triangle's vertices as tile-local grid offsets
  std::vector<std::int32_t> mid_offset;                    // each internal triangle's hypotenuse midpoint, the same
  int fit_end = 2, fit_shift = 0, root_level = 0;          // see build()
  bool skip_smooth = false;

  bool fits(int w, int h, const DepthMeshParams& p) const {
    return w == width && h == height && p.tile_px == S && p.jump_relative == jump_relative &&
           p.texture_deviation_px == texture_deviation_px && p.fit_min_leg_px == fit_min_leg_px;
  }
};

std::shared_ptr<const DepthMeshLayout> make_depth_mesh_layout(int width, int height, const DepthMeshParams& p) {
  auto l = std::make_shared<DepthMeshLayout>();
  l->width = width, l->height = height;
  l->jump_relative = p.jump_relative, l->texture_deviation_px = p.texture_deviation_px;
  l->fit_min_leg_px = p.fit_min_leg_px;
  const int S = l->S = p.tile_px;
  l->tiles_x = (width + S - 1) / S;
  l->tiles_y = (height + S - 1) / S;
  l->grid_w = l->tiles_x * S + 1;
  l->grid_h = l->tiles_y * S + 1;
  l->table = table_for(S);
  const RtinTable& t = *l->table;
  const int first_leaf = l->first_leaf = t.first_leaf(), end = l->end = t.end();
  const int levels = l->levels = level_of(end - 1) + 1;
  const int GW = l->grid_w;
  auto& level_len = l->level_len;
  auto& level_ratio = l->level_ratio;
  level_len.resize(levels), level_ratio.resize(levels);
  for (int d = 1; d < levels; ++d) {
    const int id = 1 << d;
    const int px[3] = {t.ax[id], t.bx[id], t.cx[id]}, py[3] = {t.ay[id], t.by[id], t.cy[id]};
    for (int e = 0; e < 3; ++e) {
      const double len = std::hypot(px[e] - px[(e + 1) % 3], py[e] - py[(e + 1) % 3]);
      level_len[d][e] = static_cast<float>(len);
      level_ratio[d][e] = static_cast<float>(std::pow(1 + p.jump_relative, len));
    }
  }
  auto& level_texture_check = l->level_texture_check;
  level_texture_check.assign(levels, 0);
  for (int d = 1; d < levels; ++d) {
    const double r[3] = {level_ratio[d][0], level_ratio[d][1], level_ratio[d][2]};
    level_texture_check[d] =
        p.texture_deviation_px > 0 && texture_deviation_bound(level_len[d].data(), r) > p.texture_deviation_px * 0.999;
  }
  l->vertex_offset.resize(end);
  for (int id = 2; id < end; ++id)
    l->vertex_offset[id] = {t.ay[id] * GW + t.ax[id], t.by[id] * GW + t.bx[id], t.cy[id] * GW + t.cx[id]};
  l->mid_offset.resize(first_leaf);
  for (int id = 2; id < first_leaf; ++id)
    l->mid_offset[id] = ((t.ay[id] + t.by[id]) / 2) * GW + (t.ax[id] + t.bx[id]) / 2;
  // The plane fit runs on triangles whose legs are at least fit_min_leg_px (ids below fit_end); their moments start
  // at the finest such level (ids fit_end / 2 .. fit_end - 1), straight from its pixels.
  int fit_end = 2;
  while (fit_end < first_leaf && level_len[level_of(fit_end)][1] >= p.fit_min_leg_px - 1e-6) fit_end *= 2;
  l->fit_end = fit_end;
  l->fit_shift = level_of(first_leaf) - level_of(fit_end / 2);  // leaf id >> fit_shift: its finest fit node
  // Smooth regions skip the unfitted levels' tests. A triangle of the finest fitted level (a "root": its descendants
  // are never fitted) whose bounding box holds only valid grid points, inside the image, with every 8-neighbour
  // step within kSmoothStep, passes all of them: no vertex is invalid, no edge jumps (a path of L steps, each within
  // kSmoothStep, stays far inside (1 + jump_relative)^L), leaves are emittable, and the texture test cannot fire
  // (checked below per level, with the ratios such steps allow), and no pixel is a hole. Its whole subtree is then
  // skipped: leaves emittable, errors 0, its valid pixels all of its points. The result is the same as the full
  // tests'; the steps' margin (1.06 against 1.08) is far beyond float rounding.
  const int root_level = l->root_level = level_of(fit_end / 2);
  bool skip_smooth = fit_end > 2 && fit_end < first_leaf && kSmoothStep < 1 + p.jump_relative;
  for (int d = root_level + 1; d < levels && skip_smooth; ++d) {
    if (!level_texture_check[d]) continue;
    const int id = 1 << d;
    const int px[3] = {t.ax[id], t.bx[id], t.cx[id]}, py[3] = {t.ay[id], t.by[id], t.cy[id]};
    double r[3];  // a chain of 8-neighbour steps, as many as the edge's Chebyshev length
    for (int e = 0; e < 3; ++e)
      r[e] =
          std::pow(double(kSmoothStep), std::max(std::abs(px[e] - px[(e + 1) % 3]), std::abs(py[e] - py[(e + 1) % 3])));
    skip_smooth = texture_deviation_bound(level_len[d].data(), r) <= p.texture_deviation_px * 0.99;
  }
  l->skip_smooth = skip_smooth;
  return l;
}

namespace {

// The smooth roots of one tile (smooth_root[root - fit_end / 2], roots fit_end / 2 .. fit_end - 1). g: the tile's
// first grid point in a grid of row length GW; cells_x, cells_y: its unit cells inside the image; smooth_cell (S x S)
// and rough ((S + 1) x (S + 1), row 0 and column 0 zero) are scratch.
void mark_smooth_roots(const float* g, int GW, int S, int cells_x, int cells_y, const RtinTable& t, int fit_end,
                       std::vector<std::uint8_t>& smooth_cell, std::vector<std::int32_t>& rough,
                       std::vector<std::uint8_t>& smooth_root) {
  // A unit cell is smooth when its four grid points are valid pixels of the image and its six pairs (edges
  // and diagonals) are within kSmoothStep; a root is smooth when every cell of its bounding box is. The cells
  // row by row without branches (vectorised), and the roots' boxes from a table of rough-cell counts (each box
  // read in four loads, not cell by cell).
  std::fill(smooth_cell.begin(), smooth_cell.end(), std::uint8_t{0});
  for (int y = 0; y < cells_y; ++y)
    smooth_cells(g + static_cast<size_t>(y) * GW, g + static_cast<size_t>(y + 1) * GW, cells_x, kSmoothStep,
                 &smooth_cell[static_cast<size_t>(y) * S]);
  // rough[y * (S + 1) + x]: the cells that are not smooth among rows < y and columns < x.
  for (int y = 0; y < S; ++y) {
    int row = 0;
    for (int x = 0; x < S; ++x) {
      row += smooth_cell[static_cast<size_t>(y) * S + x] == 0;
      rough[static_cast<size_t>(y + 1) * (S + 1) + x + 1] = rough[static_cast<size_t>(y) * (S + 1) + x + 1] + row;
    }
  }
  auto rough_at = [&](int x, int y) { return rough[static_cast<size_t>(y) * (S + 1) + x]; };
  for (int root = fit_end / 2; root < fit_end; ++root) {
    const int x0 = std::min({t.ax[root], t.bx[root], t.cx[root]}), x1 = std::max({t.ax[root], t.bx[root], t.cx[root]});
    const int y0 = std::min({t.ay[root], t.by[root], t.cy[root]}), y1 = std::max({t.ay[root], t.by[root], t.cy[root]});
    smooth_root[root - fit_end / 2] = x1 <= cells_x && y1 <= cells_y &&
                                      rough_at(x1, y1) - rough_at(x0, y1) - rough_at(x1, y0) + rough_at(x0, y0) == 0;
  }
}

// A fitted triangle's error: the RMS distance in sigma units (sigma_w2: sigma_w squared) of its pixels (their
// moments mt) from the plane w = alpha u + beta v + gamma through its vertices (tile-local pixels px, py; depths z).
// Left as it is when the triangle holds no valid pixel (only holes: error 0); 0 when the snap at the image's edge
// squeezed it flat (its pixels belong to its neighbours).
void fit_error(const double px[3], const double py[3], const double z[3], const Moments& mt, double sigma_w2,
               float* err) {
  const double w[3] = {1 / z[0], 1 / z[1], 1 / z[2]};
  const double du1 = px[1] - px[0], dv1 = py[1] - py[0], dw1 = w[1] - w[0];
  const double du2 = px[2] - px[0], dv2 = py[2] - py[0], dw2 = w[2] - w[0];
  const double cross = du1 * dv2 - dv1 * du2;
  if (cross == 0) {
    *err = 0;
    return;
  }
  const double alpha = (dw1 * dv2 - dw2 * dv1) / cross, beta = (du1 * dw2 - du2 * dw1) / cross;
  const double gamma = w[0] - alpha * px[0] - beta * py[0];
  if (mt.n <= 0) return;
  const double sse = mt.sww - 2 * (alpha * mt.suw + beta * mt.svw + gamma * mt.sw) + alpha * alpha * mt.suu +
                     2 * alpha * beta * mt.suv + beta * beta * mt.svv + 2 * alpha * gamma * mt.su +
                     2 * beta * gamma * mt.sv + gamma * gamma * mt.n;
  *err = static_cast<float>(std::sqrt(std::max(0.0, sse) / (mt.n * sigma_w2)));  // (one division)
}

// Martini's propagation, finest level first over all tiles (so a midpoint on a tile border holds both tiles'
// errors before any parent reads it): error(m) = max(own, children's midpoints), into the grid E (zeros, grid_w x
// grid_h) from each tile's triangle errors (first_leaf a tile). Serial: it is a few loads and a max a triangle, with
// midpoints as tile-local grid offsets computed once (a level-synchronous parallel version spent more in its
// barriers than it saved on a loaded machine).
void propagate_to_midpoints(const DepthMeshLayout& L, const std::vector<float>& tri_error, float* E) {
  const int S = L.S, GW = L.grid_w, first_leaf = L.first_leaf, tiles = L.tiles_x * L.tiles_y;
  const auto& mid_offset = L.mid_offset;
  for (int lb = first_leaf / 2; lb >= 2; lb /= 2) {
    const bool children_split = 2 * lb < first_leaf;
    for (int tile = 0; tile < tiles; ++tile) {
      float* base = E + static_cast<size_t>((tile / L.tiles_x) * S) * GW + (tile % L.tiles_x) * S;
      const float* err = &tri_error[static_cast<size_t>(tile) * first_leaf];
      for (int id = lb; id < 2 * lb; ++id) {
        float e = err[id];
        if (children_split) e = std::max({e, base[mid_offset[2 * id]], base[mid_offset[2 * id + 1]]});
        float& slot = base[mid_offset[id]];
        slot = std::max(slot, e);
      }
    }
  }
}

}  // namespace

Result<DepthMeshHierarchy> DepthMeshHierarchy::build(const cv::Mat& depth_m, const cv::Mat& vertex_depth_m,
                                                     const Intrinsics& k, const DepthMeshParams& p, int threads,
                                                     std::shared_ptr<const DepthMeshLayout> layout) {
  if (auto st = p.validate(); !st) return st.error();
  if (depth_m.empty() || depth_m.type() != CV_32FC1)
    return make_error(ErrorCode::kInvalidArgument, "depth mesh: depth must be a non-empty CV_32FC1 image");
  if (vertex_depth_m.size() != depth_m.size() || vertex_depth_m.type() != CV_32FC1)
    return make_error(ErrorCode::kInvalidArgument, "depth mesh: vertex depth must be CV_32FC1 of the depth's size");
  if (!(std::isfinite(k.fx) && std::isfinite(k.fy) && k.fx > 0 && k.fy > 0 && std::isfinite(k.cx) &&
        std::isfinite(k.cy)))
    return make_error(ErrorCode::kInvalidArgument, "depth mesh: intrinsics must be finite with fx, fy > 0");
  const std::shared_ptr<const DepthMeshLayout> L = layout && layout->fits(depth_m.cols, depth_m.rows, p)
                                                       ? layout
                                                       : make_depth_mesh_layout(depth_m.cols, depth_m.rows, p);
  DepthMeshHierarchy h;
  h.width_ = depth_m.cols;
  h.height_ = depth_m.rows;
  h.k_ = k;
  h.params_ = p;
  const int S = h.tile_ = L->S;
  h.tiles_x_ = L->tiles_x;
  h.tiles_y_ = L->tiles_y;
  h.grid_w_ = L->grid_w;
  const int grid_h = L->grid_h;
  h.table_ = L->table;
  const RtinTable& t = *h.table_;

  // Grid points are pixel centres. The one column and row just past the image (x = width, y = height) repeat the
  // last pixel's depth and sit on it (snap()): tiles of 2^k pixels then end exactly on the image's last pixel, with
  // degenerate leaves between the two, which are never emitted. Points further out are invalid.
  h.depth_.assign(static_cast<size_t>(h.grid_w_) * grid_h, 0.f);
  for (int y = 0; y <= h.height_ && y < grid_h; ++y) {
    const float* z = vertex_depth_m.ptr<float>(std::min(y, h.height_ - 1));
    float* row = h.depth_.data() + static_cast<size_t>(y) * h.grid_w_;
    for (int x = 0; x < h.width_; ++x)  // (vectorised: no index clamp inside)
      row[x] = z[x] > 0.f && z[x] <= std::numeric_limits<float>::max() ? z[x] : 0.f;  // (NaN and +inf fail both)
    if (h.width_ < h.grid_w_) row[h.width_] = row[h.width_ - 1];
  }
  const int first_leaf = L->first_leaf, end = L->end, levels = L->levels;
  const int GW = h.grid_w_;
  const auto& level_len = L->level_len;
  const auto& level_ratio = L->level_ratio;
  const auto& level_texture_check = L->level_texture_check;
  const auto& vertex_offset = L->vertex_offset;
  const int fit_end = L->fit_end, fit_shift = L->fit_shift, root_level = L->root_level;
  const bool skip_smooth = L->skip_smooth;

  const int tiles = h.tiles_x_ * h.tiles_y_;
  std::vector<float> tri_error(static_cast<size_t>(tiles) * first_leaf, 0.f);
  h.leaf_ok_.assign(static_cast<size_t>(tiles) * (end - first_leaf), 0);
  const double sigma_w2 = p.noise_m_per_m2 * p.noise_m_per_m2;
  const double max_lost = p.boundary_max_lost_px;
  const std::vector<float>& D = h.depth_;

  // Tiles are independent: up to `threads` workers take them in turn. Plain threads joined here, not an OpenMP
  // team: libgomp's idle team spins after a region, and on a loaded 2-core machine that spin slowed every serial
  // stage after this one (extraction 2.6 -> 10.7 ms on TUM 200-319 frame 0).
  std::atomic<int> next_tile{0};
  auto work = [&] {
    std::vector<Moments> m(fit_end);                  // the fitted triangles' pixel moments
    std::vector<std::uint16_t> valid_px(first_leaf);  // every internal triangle's valid pixels
    std::vector<std::uint8_t> smooth_cell(skip_smooth ? static_cast<size_t>(S) * S : 0);
    std::vector<std::uint8_t> smooth_root(skip_smooth ? fit_end / 2 : 0);  // by root id - fit_end / 2
    std::vector<std::int32_t> rough(skip_smooth ? static_cast<size_t>(S + 1) * (S + 1) : 0, 0);  // (row 0, column 0: 0)
    for (int tile; (tile = next_tile++) < tiles;) {
      const int ox = (tile % h.tiles_x_) * S, oy = (tile / h.tiles_x_) * S;
      if (skip_smooth)
        mark_smooth_roots(D.data() + static_cast<size_t>(oy) * GW + ox, GW, S, std::min(S, h.width_ - 1 - ox),
                          std::min(S, h.height_ - 1 - oy), t, fit_end, smooth_cell, rough, smooth_root);
      const int finest_fit = fit_end / 2;
      for (int id = finest_fit; id < fit_end && fit_end > 2; ++id) m[id] = Moments{};
      std::fill(valid_px.begin() + first_leaf / 2, valid_px.end(), std::uint16_t{0});
      // Pixels: each grid point of the tile belongs to one leaf; its valid pixel counts for the leaf's parent and
      // goes into the moments of the leaf's finest fitted ancestor.
      // (The tile's pixels through one row pointer and step; x and y from the table: the division by S and
      // cv::Mat::at's reloads were half of this loop's time, ahead of each depth load.)
      const float* tile_px = depth_m.ptr<float>(oy) + ox;
      const size_t step = depth_m.step1();
      const int in_w = h.width_ - ox, in_h = h.height_ - oy;  // the tile's points inside the image: x < in_w, y < in_h
      for (int leaf = first_leaf; leaf < end; ++leaf) {
        const int x = t.point_x[leaf - first_leaf], y = t.point_y[leaf - first_leaf];
        if (x < 0 || x >= in_w || y >= in_h) continue;
        const float z = tile_px[static_cast<size_t>(y) * step + x];
        if (!(z > 0.f)) continue;
        ++valid_px[leaf >> 1];
        if (fit_end <= 2) continue;
        Moments& mt = m[leaf >> fit_shift];
        const double w = 1.0 / z, u = x, v = y;
        mt.n += 1, mt.su += u, mt.sv += v, mt.sw += w, mt.suu += u * u, mt.suv += u * v, mt.svv += v * v;
        mt.suw += u * w, mt.svw += v * w, mt.sww += w * w;
      }
      const float* base = D.data() + static_cast<size_t>(oy) * GW + ox;
      // Tile-local coordinates of a vertex after the snap onto the image's last pixel.
      auto sx = [&](int x) { return double(std::min(ox + x, h.width_ - 1) - ox); };
      auto sy = [&](int y) { return double(std::min(oy + y, h.height_ - 1) - oy); };
      auto within = [](float a, float b, float ratio) { return std::max(a, b) <= std::min(a, b) * ratio; };
      // Leaves: emittable when the three vertices are valid and no edge jumps in depth.
      std::uint8_t* leaf_ok = &h.leaf_ok_[static_cast<size_t>(tile) * (end - first_leaf)];
      const auto& leaf_ratio = level_ratio[levels - 1];
      auto leaf_test = [&](int id) {
        const auto& o = vertex_offset[id];
        const float za = base[o[0]], zb = base[o[1]], zc = base[o[2]];
        if (za <= 0 || zb <= 0 || zc <= 0) return;
        leaf_ok[id - first_leaf] =
            within(za, zb, leaf_ratio[0]) && within(zb, zc, leaf_ratio[1]) && within(zc, za, leaf_ratio[2]);
      };
      // A smooth root's leaves (a contiguous run of ids) are all emittable.
      const int leaf_depth = levels - 1 - root_level;
      if (skip_smooth) {
        for (int root = fit_end / 2; root < fit_end; ++root) {
          const int lo = root << leaf_depth, hi = (root + 1) << leaf_depth;
          if (smooth_root[root - fit_end / 2])
            std::fill(leaf_ok + (lo - first_leaf), leaf_ok + (hi - first_leaf), 1);
          else
            for (int id = lo; id < hi; ++id) leaf_test(id);
        }
      } else {
        for (int id = first_leaf; id < end; ++id) leaf_test(id);
      }
      float* err = &tri_error[static_cast<size_t>(tile) * first_leaf];
      auto visit = [&](int id) {
        const int level = level_of(id);
        const bool fitted = id < fit_end;
        // A smooth root's pixels are all valid (its subtree was skipped whole).
        if (id < first_leaf / 2)
          valid_px[id] = skip_smooth && fitted && id >= fit_end / 2 && smooth_root[id - fit_end / 2]
                             ? t.points_of[id]
                             : valid_px[2 * id] + valid_px[2 * id + 1];
        if (fitted && id < finest_fit) {  // the moments add up whatever this triangle's verdict
          m[id] = m[2 * id];
          m[id].add(m[2 * id + 1]);
        }
        const auto& o = vertex_offset[id];
        const float za = base[o[0]], zb = base[o[1]], zc = base[o[2]];
        const double n = valid_px[id];
        if (za <= 0 || zb <= 0 || zc <= 0) {
          // On the edge of the valid depth: a triangle that stays whole here is not emitted, so its valid pixels
          // beyond those along one edge (which its neighbour across that edge covers) would be lost. Its error
          // is that loss, boundary_px_per_sigma pixels to a sigma, up to boundary_max_lost_px: past that it
          // splits whatever the tolerance, so a byte budget trades interior detail, not coverage, for bytes.
          const double lost = std::max(0.0, n - (level_len[level][0] + 1));
          err[id] = lost > max_lost ? kInf : static_cast<float>(lost / p.boundary_px_per_sigma);
          return;
        }
        const double total = t.points_of[id];
        const auto& ratio = level_ratio[level];
        if (total - n > p.max_hole_fraction * total || !within(za, zb, ratio[0]) || !within(zb, zc, ratio[1]) ||
            !within(zc, za, ratio[2])) {
          err[id] = kInf;
          return;
        }
        if (!fitted && !level_texture_check[level]) return;  // error 0
        const double z[3] = {za, zb, zc};
        const double px[3] = {sx(t.ax[id]), sx(t.bx[id]), sx(t.cx[id])};
        const double py[3] = {sy(t.ay[id]), sy(t.by[id]), sy(t.cy[id])};
        if (level_texture_check[level] &&
            texture_deviates(px, py, z, level_len[level].data(), p.texture_deviation_px)) {
          err[id] = kInf;
          return;
        }
        if (!fitted) return;  // below fit_min_leg_px: error 0
        fit_error(px, py, z, m[id], sigma_w2, &err[id]);
      };
      // The unfitted levels subtree by subtree, finest level first (a triangle reads only its children): a smooth
      // root's subtree passes every test with error 0 (see kSmoothStep) and is skipped whole. Then the fitted levels.
      const int internal_depth = levels - 2 - root_level;  // unfitted internal levels below a root
      if (fit_end < first_leaf)
        for (int root = fit_end / 2; root < fit_end; ++root) {
          if (skip_smooth && smooth_root[root - fit_end / 2]) continue;
          for (int k = internal_depth; k >= 1; --k)
            for (int id = root << k; id < (root + 1) << k; ++id) visit(id);
        }
      for (int id = std::min(fit_end, first_leaf) - 1; id >= 2; --id) visit(id);
    }
  };
  run_workers(std::clamp(openmp_threads(threads), 1, tiles), [&](int) { work(); });

  h.error_.assign(h.depth_.size(), 0.f);
  propagate_to_midpoints(*L, tri_error, h.error_.data());
  return h;
}

template <class Emit>
void DepthMeshHierarchy::walk(double tol, Emit&& emit) const {
  const RtinTable& t = *table_;
  const int S = tile_, first_leaf = t.first_leaf(), end = t.end();
  std::vector<int> stack;
  for (int tile = 0; tile < tiles_x_ * tiles_y_; ++tile) {
    const int ox = (tile % tiles_x_) * S, oy = (tile / tiles_x_) * S;
    const std::uint8_t* leaf_ok = &leaf_ok_[static_cast<size_t>(tile) * (end - first_leaf)];
    stack.assign({2, 3});
    while (!stack.empty()) {
      const int id = stack.back();
      stack.pop_back();
      if (id >= first_leaf) {
        if (leaf_ok[id - first_leaf]) emit(ox, oy, id);
        continue;
      }
      const size_t m = static_cast<size_t>(oy + (t.ay[id] + t.by[id]) / 2) * grid_w_ + (ox + (t.ax[id] + t.bx[id]) / 2);
      if (error_[m] > tol) {
        stack.push_back(2 * id + 1);
        stack.push_back(2 * id);
      } else if (depth_[static_cast<size_t>(oy + t.ay[id]) * grid_w_ + ox + t.ax[id]] > 0 &&
                 depth_[static_cast<size_t>(oy + t.by[id]) * grid_w_ + ox + t.bx[id]] > 0 &&
                 depth_[static_cast<size_t>(oy + t.cy[id]) * grid_w_ + ox + t.cx[id]] > 0) {
        emit(ox, oy, id);
      }
    }
  }
}

namespace {
// Tolerance bins: a non-negative float's bits are monotone in its value; the top 16 keep 7 mantissa bits.
int tolerance_bin(double v) {
  const float f = static_cast<float>(std::min<double>(std::max(v, 0.0), std::numeric_limits<float>::max()));
  std::uint32_t bits;
  std::memcpy(&bits, &f, sizeof bits);
  return static_cast<int>(bits >> 16);
}
double bin_top(int bin) {
  const std::uint32_t bits = (static_cast<std::uint32_t>(bin) << 16) | 0xffffu;
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}
constexpr int kInfBin = 0x7f80;  // +inf's bin
}  // namespace

DepthMeshHierarchy::TriangleCounts DepthMeshHierarchy::counts(double tol, int threads) const {
  TriangleCounts c;
  c.min_ = std::max(tol, 0.0);
  c.first_bin_ = tolerance_bin(c.min_);
  const size_t bins = static_cast<size_t>(kInfBin - c.first_bin_ + 2);
  const RtinTable& t = *table_;
  const int S = tile_, first_leaf = t.first_leaf(), end = t.end(), tiles = tiles_x_ * tiles_y_;
  // Tiles are independent: each worker walks its share into its own difference array (emitted while
  // own <= t < parent: +1 at own's bin, -1 at parent's), and the arrays are added. Plain threads, as in build().
  struct Partial {
    std::vector<std::int64_t> diff;
    size_t at_min = 0;
  };
  const int workers = std::clamp(threads, 1, std::max(1, tiles / 4));
  std::vector<Partial> partial(workers);
  auto work = [&](int worker) {
    Partial& p = partial[worker];
    p.diff.assign(bins, 0);
    auto add = [&](float own, float parent) {
      const int lo = std::max(tolerance_bin(own), c.first_bin_), hi = tolerance_bin(parent);
      if (own <= c.min_ && c.min_ < parent) ++p.at_min;
      if (hi <= lo) return;
      ++p.diff[lo - c.first_bin_];
      --p.diff[hi - c.first_bin_];
    };
    std::vector<std::pair<int, float>> stack;  // (id, parent's error)
    for (int tile = worker; tile < tiles; tile += workers) {
      const int ox = (tile % tiles_x_) * S, oy = (tile / tiles_x_) * S;
      const std::uint8_t* leaf_ok = &leaf_ok_[static_cast<size_t>(tile) * (end - first_leaf)];
      stack.assign({{2, kInf}, {3, kInf}});
      while (!stack.empty()) {
        const auto [id, parent] = stack.back();
        stack.pop_back();
        if (id >= first_leaf) {
          if (leaf_ok[id - first_leaf]) add(0.f, parent);
          continue;
        }
        const float e =
            error_[static_cast<size_t>(oy + (t.ay[id] + t.by[id]) / 2) * grid_w_ + (ox + (t.ax[id] + t.bx[id]) / 2)];
        if (depth_[static_cast<size_t>(oy + t.ay[id]) * grid_w_ + ox + t.ax[id]] > 0 &&
            depth_[static_cast<size_t>(oy + t.by[id]) * grid_w_ + ox + t.bx[id]] > 0 &&
            depth_[static_cast<size_t>(oy + t.cy[id]) * grid_w_ + ox + t.cx[id]] > 0)
          add(e, parent);
        if (e > c.min_) {
          stack.push_back({2 * id + 1, e});
          stack.push_back({2 * id, e});
        }
      }
    }
  };
  run_workers(workers, work);
  c.counts_.resize(bins);
  std::int64_t run = 0;
  for (size_t i = 0; i < bins; ++i) {
    for (const Partial& p : partial) run += p.diff[i];
    c.counts_[i] = run;
  }
  for (const Partial& p : partial) c.at_min_ += p.at_min;
  return c;
}

double DepthMeshHierarchy::TriangleCounts::bin_top_of(double tol) { return bin_top(tolerance_bin(tol)); }

size_t DepthMeshHierarchy::TriangleCounts::at(double tol) const {
  if (tol <= min_) return at_min_;
  const int bin = tolerance_bin(tol) - first_bin_;
  return static_cast<size_t>(counts_[std::min<size_t>(static_cast<size_t>(bin), counts_.size() - 1)]);
}

double DepthMeshHierarchy::TriangleCounts::smallest_with_at_most(double triangles, double tol_max) const {
  if (static_cast<double>(at_min_) <= triangles || tol_max <= min_) return min_;
  const int last = std::min<int>(tolerance_bin(tol_max) - first_bin_, static_cast<int>(counts_.size()) - 1);
  for (int bin = 0; bin <= last; ++bin)  // counts fall as the tolerance grows
    if (static_cast<double>(counts_[bin]) <= triangles) return bin_top(bin + first_bin_);
  return bin_top(last + first_bin_);
}

Mesh DepthMeshHierarchy::extract(double tol, std::vector<Eigen::Vector2i>* pixels,
                                 std::vector<std::uint32_t>* edge_uses) const {
  const RtinTable& t = *table_;
  // Triangles as grid point ids, counter-clockwise seen from the camera (negative signed area with v down).
  std::vector<std::uint32_t> tris;
  auto snapped = [&](std::uint32_t g) {
    return Eigen::Vector2d(std::min<int>(g % grid_w_, width_ - 1), std::min<int>(g / grid_w_, height_ - 1));
  };
  const double r = params_.boundary_push_px;
  const bool count_edges = r > 0 || edge_uses;
  // Each index slot's edge (slot k of a triangle: from its vertex k to the next) as its midpoint on the doubled grid,
  // (ya + yb) * 2 W + (xa + xb): the triangles of an RTIN never cross, so no two edges share a midpoint, and counting
  // the slots at each midpoint counts each edge's triangles (what edge_use_counts does by sorting, in a third of the
  // time).
  const std::uint32_t mid_w = 2 * static_cast<std::uint32_t>(grid_w_);
  std::vector<std::uint32_t> mids;
  walk(tol, [&](int ox, int oy, int id) {
    const std::uint32_t xa = ox + t.ax[id], ya = oy + t.ay[id], xb = ox + t.bx[id], yb = oy + t.by[id];
    const std::uint32_t xc = ox + t.cx[id], yc = oy + t.cy[id];
    const std::uint32_t a = ya * grid_w_ + xa, b = yb * grid_w_ + xb, c = yc * grid_w_ + xc;
    // The signed area of the snapped pixels (snapped() without its divisions).
    const int W1 = width_ - 1, H1 = height_ - 1;
    const int pax = std::min<int>(xa, W1), pay = std::min<int>(ya, H1), pbx = std::min<int>(xb, W1),
              pby = std::min<int>(yb, H1), pcx = std::min<int>(xc, W1), pcy = std::min<int>(yc, H1);
    const double cross = double(pbx - pax) * (pcy - pay) - double(pby - pay) * (pcx - pax);
    if (cross == 0) return;  // a leaf squeezed flat by the snap
    const std::uint32_t ab = (ya + yb) * mid_w + xa + xb, bc = (yb + yc) * mid_w + xb + xc,
                        ca = (yc + ya) * mid_w + xc + xa;
    if (cross < 0) {
      tris.insert(tris.end(), {a, b, c});
      if (count_edges) mids.insert(mids.end(), {ab, bc, ca});
    } else {
      tris.insert(tris.end(), {a, c, b});
      if (count_edges) mids.insert(mids.end(), {ca, bc, ab});
    }
  });
  Mesh mesh;
  if (tris.empty()) return mesh;

  std::vector<std::int32_t> remap(depth_.size(), -1);
  std::vector<std::uint32_t> grid_of_vertex;
  mesh.indices.reserve(tris.size());
  for (std::uint32_t g : tris) {
    if (remap[g] < 0) {
      remap[g] = static_cast<std::int32_t>(grid_of_vertex.size());
      grid_of_vertex.push_back(g);
    }
    mesh.indices.push_back(static_cast<std::uint32_t>(remap[g]));
  }
  // Each boundary vertex (on an edge of one triangle) moves outwards, perpendicular to the edge in the image: the
  // sum of its boundary edges' outward normals, each axis clamped to the push, along the inverse-depth plane of its
  // boundary triangles so that it stays on their surface.
  const size_t nv = grid_of_vertex.size();
  std::vector<Eigen::Vector2d> push(nv, Eigen::Vector2d::Zero()), gradient(nv, Eigen::Vector2d::Zero());
  std::vector<int> gradient_count(nv, 0);
  auto pixel = [&](std::uint32_t g) { return snapped(g); };
  std::vector<std::uint32_t> uses;
  if (count_edges) {
    std::vector<std::uint8_t> at_mid(static_cast<size_t>(mid_w) * 2 * depth_.size() / grid_w_, 0);
    for (std::uint32_t m : mids) ++at_mid[m];  // (at most 2 triangles on an edge)
    uses.resize(mids.size());
    for (size_t s = 0; s < mids.size(); ++s) uses[s] = at_mid[mids[s]];
  }
  if (r > 0) {
    for (size_t i = 0; i < tris.size(); i += 3) {
      for (int e = 0; e < 3; ++e) {
        if (uses[i + e] != 1) continue;
        const std::uint32_t a = tris[i + e], b = tris[i + (e + 1) % 3], c = tris[i + (e + 2) % 3];
        const Eigen::Vector2d pa = pixel(a), pb = pixel(b), pc = pixel(c);
        Eigen::Vector2d n(pb.y() - pa.y(), pa.x() - pb.x());
        n.normalize();
        if (n.dot(pc - pa) > 0) n = -n;
        // The triangle's plane in (u, v, w): w = w_a + g . (p - p_a).
        const double wa = 1.0 / depth_[a], wb = 1.0 / depth_[b], wc = 1.0 / depth_[c];
        const Eigen::Vector2d d1 = pb - pa, d2 = pc - pa;
        const double det = d1.x() * d2.y() - d1.y() * d2.x();
        const Eigen::Vector2d g(((wb - wa) * d2.y() - (wc - wa) * d1.y()) / det,
                                ((wc - wa) * d1.x() - (wb - wa) * d2.x()) / det);
        for (std::uint32_t v : {a, b}) {
          push[remap[v]] += n;
          gradient[remap[v]] += g;
          ++gradient_count[remap[v]];
        }
      }
    }
    for (size_t i = 0; i < nv; ++i) push[i] = (r * push[i]).cwiseMax(-r).cwiseMin(r);
    // A push must not fold a small triangle over: such vertices stay where they are.
    for (int pass = 0; pass < 2; ++pass)
      for (size_t i = 0; i < tris.size(); i += 3) {
        const std::uint32_t ia = mesh.indices[i], ib = mesh.indices[i + 1], ic = mesh.indices[i + 2];
        const Eigen::Vector2d a = pixel(tris[i]) + push[ia], b = pixel(tris[i + 1]) + push[ib],
                              c = pixel(tris[i + 2]) + push[ic];
        const double area = (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
        if (area > -0.1) push[ia] = push[ib] = push[ic] = Eigen::Vector2d::Zero();
      }
  }
  mesh.positions.resize(nv);
  if (pixels) pixels->resize(nv);
  for (size_t i = 0; i < nv; ++i) {
    const std::uint32_t g = grid_of_vertex[i];
    const Eigen::Vector2d p = pixel(g);
    double z = depth_[g];
    if (gradient_count[i] > 0 && push[i].squaredNorm() > 0) {
      const double w = 1.0 / z + (gradient[i] / gradient_count[i]).dot(push[i]);
      if (w > 0 && std::abs(std::log(w * z)) < std::log1p(params_.jump_relative)) z = 1.0 / w;
    }
    mesh.positions[i] = k_.backproject(p.x() + push[i].x(), p.y() + push[i].y(), z).cast<float>();
    if (pixels) (*pixels)[i] = {static_cast<int>(p.x()), static_cast<int>(p.y())};
  }
  if (edge_uses) *edge_uses = std::move(uses);
  return mesh;
}

}  // namespace rgbdcast
