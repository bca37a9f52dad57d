#include "atlas/footprint_layout.h"

#include <algorithm>
#include <cmath>

#include "atlas/atlas_layout.h"

namespace rgbdcast {

const std::vector<int>& footprint_leg_classes() {
  static const std::vector<int> classes = [] {
    std::vector<int> c;
    for (int k = 0; k <= 16; ++k) {
      const int n = static_cast<int>(std::ceil(std::pow(2.0, k / 2.0) - 1e-9));
      if (c.empty() || n != c.back()) c.push_back(n);
    }
    return c;
  }();
  return classes;
}

int footprint_leg_class(double leg_px) {
  const auto& c = footprint_leg_classes();
  if (!(leg_px > 1.0)) return c.front();
  const auto it = std::lower_bound(c.begin(), c.end(), leg_px - 1e-3);
  return it == c.end() ? c.back() : *it;
}

double footprint_leg_px(const std::array<Eigen::Vector2d, 3>& p, int* right_angle) {
  int best = 0;
  double best_cos = 2.0;
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector2d a = p[(i + 1) % 3] - p[i], b = p[(i + 2) % 3] - p[i];
    const double na = a.norm(), nb = b.norm();
    const double cosine = (na > 0 && nb > 0) ? a.dot(b) / (na * nb) : 1.0;
    if (cosine < best_cos) best_cos = cosine, best = i;
  }
  if (right_angle) *right_angle = best;
  const Eigen::Vector2d e1 = p[(best + 1) % 3] - p[best], e2 = p[(best + 2) % 3] - p[best];
  // Largest singular value of [e1 e2]: sqrt of the largest eigenvalue of its Gram matrix.
  const double a = e1.squaredNorm(), b = e1.dot(e2), c = e2.squaredNorm();
  const double half_diff = 0.5 * (a - c);
  return std::sqrt(0.5 * (a + c) + std::sqrt(half_diff * half_diff + b * b));
}

std::array<Eigen::Vector2d, 3> FootprintLayout::corners(size_t t) const {
  const FootprintSlot& s = slots[t];
  if (!s.diamond) return cell_triangle_corners(s.x0, s.y0, s.cell_px, gutter_px, true, s.lower);
  // The square [g, S - g]^2 split along its diagonal from (S - g, g) to (g, S - g).
  const double g = gutter_px, f = s.cell_px - gutter_px;
  const Eigen::Vector2d o(s.x0, s.y0), top_right = o + Eigen::Vector2d(f, g), bottom_left = o + Eigen::Vector2d(g, f);
  if (!s.lower) return {o + Eigen::Vector2d(g, g), top_right, bottom_left};
  if (s.swapped) return {o + Eigen::Vector2d(f, f), top_right, bottom_left};
  return {o + Eigen::Vector2d(f, f), bottom_left, top_right};
}

double FootprintLayout::efficiency() const {
  const double texels = static_cast<double>(width) * height;
  return texels > 0 ? triangle_texels / texels : 0.0;
}

bool make_footprint_layout(const std::vector<FootprintTriangle>& tris, int gutter_px, int max_side,
                           FootprintLayout* out, const std::vector<std::pair<int, int>>& patch_sizes) {
  if (gutter_px < 0 || gutter_px > 64) return false;
  FootprintLayout l;
  l.gutter_px = gutter_px;
  l.slots.resize(tris.size());
  const auto side = [&](int leg, bool diamond) { return leg + (diamond ? 2 * gutter_px : 3 * gutter_px + 1); };

  // Cells: diamonds (at their first triangle), then pairs of consecutive other triangles of the same leg; biggest
  // cells first, triangle order within a size.
  struct Cell {
    int side, leg;
    bool diamond;
    std::uint32_t first, second;  // second == first when alone
    int height = 0;               // patches: their size is (side = width) x height; triangle cells are square
    std::int64_t patch = -1;
  };
  std::vector<Cell> cells;
  cells.reserve(tris.size() / 2 + 1);
  std::vector<std::uint32_t> loose;  // triangles without a partner
  for (size_t t = 0; t < tris.size(); ++t) {
    const FootprintTriangle& tri = tris[t];
    if (tri.leg <= 0) return false;
    const std::int64_t p = tri.diamond_partner;
    if (p < 0) {
      loose.push_back(static_cast<std::uint32_t>(t));
      continue;
    }
    if (p >= static_cast<std::int64_t>(tris.size()) || p == static_cast<std::int64_t>(t) ||
        tris[p].diamond_partner != static_cast<std::int64_t>(t))
      return false;
    if (p < static_cast<std::int64_t>(t)) continue;  // laid out with its first triangle
    const int leg = std::max(tri.leg, tris[p].leg);
    cells.push_back({side(leg, true), leg, true, static_cast<std::uint32_t>(t), static_cast<std::uint32_t>(p)});
  }
  std::stable_sort(loose.begin(), loose.end(),
                   [&](std::uint32_t a, std::uint32_t b) { return tris[a].leg > tris[b].leg; });
  for (size_t k = 0; k < loose.size();) {
    const int leg = tris[loose[k]].leg;
    const bool pair = k + 1 < loose.size() && tris[loose[k + 1]].leg == leg;
    cells.push_back({side(leg, false), leg, false, loose[k], pair ? loose[k + 1] : loose[k]});
    k += pair ? 2 : 1;
  }
  for (const Cell& c : cells) l.triangle_texels += 0.5 * c.leg * c.leg;
  for (Cell& c : cells) c.height = c.side;
  l.patch_origins.resize(patch_sizes.size());
  for (size_t k = 0; k < patch_sizes.size(); ++k) {
    if (patch_sizes[k].first <= 0 || patch_sizes[k].second <= 0) return false;
    Cell c{patch_sizes[k].first, 0, false, 0, 0, patch_sizes[k].second, static_cast<std::int64_t>(k)};
    cells.push_back(c);
  }
  // Tallest first, then widest (shelves), stable.
  std::stable_sort(cells.begin(), cells.end(), [](const Cell& a, const Cell& b) {
    return a.height != b.height ? a.height > b.height : a.side > b.side;
  });
  double area = 0;
  for (const Cell& c : cells) {
    if (c.side > max_side || c.height > max_side) return false;
    area += double(c.side) * c.height;
    if (c.patch >= 0) continue;
    const bool pair = c.second != c.first;
    // Own areas: a split cell's lower triangle has legs one texel longer (atlas_layout.h); a diamond's are equal.
    if (pair) l.triangle_texels += c.diamond ? 0.5 * c.leg * c.leg : 0.5 * (c.leg + 1) * (c.leg + 1);
  }
  l.cells = cells.size() - patch_sizes.size();
  l.cell_texels = area;
  if (cells.empty()) {
    l.width = l.height = 8;
    *out = std::move(l);
    return true;
  }

  int widest = 0;
  for (const Cell& c : cells) widest = std::max(widest, c.side);
  int width = std::max(widest, static_cast<int>(std::ceil(std::sqrt(area))));
  width = (width + 7) / 8 * 8;
  if (width > max_side) return false;
  int shelf_y = 0, shelf_h = 0, x = 0;             // current shelf and the next free column in it
  int col_x = 0, col_w = 0, col_h = 0, col_y = 0;  // current column: where the next item of its size goes
  auto place = [&](const Cell& c, int cx, int cy) {
    if (c.patch >= 0) {
      l.patch_origins[c.patch] = {cx, cy};
      return;
    }
    FootprintSlot s{cx, cy, c.side, false, c.second != c.first, c.diamond, false};
    l.slots[c.first] = s;
    if (s.paired) {
      s.lower = true;
      s.swapped = c.diamond && tris[c.second].swapped;
      l.slots[c.second] = s;
    }
  };
  for (const Cell& c : cells) {
    if (shelf_h > 0 && col_w == c.side && col_h == c.height && col_y + c.height <= shelf_y + shelf_h) {
      place(c, col_x, col_y);
      col_y += c.height;
      continue;
    }
    if (shelf_h == 0 || x + c.side > width) {  // a new shelf, as high as this item
      shelf_y += shelf_h;
      shelf_h = c.height;
      x = 0;
    }
    col_x = x;
    col_w = c.side;
    col_h = c.height;
    place(c, col_x, shelf_y);
    col_y = shelf_y + c.height;
    x += c.side;
  }
  const int height = (shelf_y + shelf_h + 7) / 8 * 8;
  if (height > max_side) return false;
  l.width = width;
  l.height = height;
  *out = std::move(l);
  return true;
}

}  // namespace rgbdcast
