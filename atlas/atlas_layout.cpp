#include "atlas/atlas_layout.h"

#include <cmath>

namespace rgbdcast {

void CellLayout::cell_of(size_t slot, int* x0, int* y0, bool* lower) const {
  const size_t cell = two_per_cell ? slot / 2 : slot;
  *lower = two_per_cell && (slot % 2 == 1);
  *x0 = static_cast<int>(cell % columns) * cell_px;
  *y0 = static_cast<int>(cell / columns) * cell_px;
}

std::array<Eigen::Vector2d, 3> cell_triangle_corners(int x0, int y0, int cell_px, int gutter_px, bool two_per_cell,
                                                     bool lower) {
  const double S = cell_px, g = gutter_px;
  const Eigen::Vector2d o(x0, y0);
  if (!two_per_cell) return {o + Eigen::Vector2d(g, g), o + Eigen::Vector2d(S - g, g), o + Eigen::Vector2d(g, S - g)};
  if (!lower)
    return {o + Eigen::Vector2d(g, g), o + Eigen::Vector2d(S - 2 * g - 1, g), o + Eigen::Vector2d(g, S - 2 * g - 1)};
  return {o + Eigen::Vector2d(S - g, S - g), o + Eigen::Vector2d(2 * g, S - g), o + Eigen::Vector2d(S - g, 2 * g)};
}

std::array<Eigen::Vector2d, 3> CellLayout::corners(size_t slot) const {
  int x0, y0;
  bool lower;
  cell_of(slot, &x0, &y0, &lower);
  return cell_triangle_corners(x0, y0, cell_px, gutter_px, two_per_cell, lower);
}

int CellLayout::leg_px() const { return two_per_cell ? cell_px - 3 * gutter_px - 1 : cell_px - 2 * gutter_px; }

bool make_cell_layout(size_t triangles, int cell_px, int gutter_px, bool two_per_cell, int max_side, CellLayout* out) {
  if (gutter_px < 0 || cell_px < 3 * gutter_px + 2 || cell_px > 4096) return false;
  CellLayout l;
  l.cell_px = cell_px;
  l.gutter_px = gutter_px;
  l.two_per_cell = two_per_cell;
  l.cells = two_per_cell ? (triangles + 1) / 2 : triangles;
  if (l.cells == 0) l.cells = 1;
  l.columns = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(l.cells))));
  l.rows = static_cast<int>((l.cells + l.columns - 1) / l.columns);
  if (static_cast<long long>(l.columns) * cell_px > max_side || static_cast<long long>(l.rows) * cell_px > max_side)
    return false;
  l.width = l.columns * cell_px;
  l.height = l.rows * cell_px;
  *out = l;
  return true;
}

}  // namespace rgbdcast
