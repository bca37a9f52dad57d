// An inner tile's content: its children's surfaces welded, simplified (meshoptimizer), and textured from them.
#include <meshoptimizer.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <optional>
#include <unordered_map>
#include <unordered_set>

#include <unsupported/Eigen/BVH>

#include "atlas/cell_fill.h"
#include "tiles/tile_bake.h"
#include "tiles/tile_content.h"

namespace rgbdcast::tiles {
namespace {

constexpr double kWeldStepM = 0.001;  // children's GLBs are quantized to 1 mm; their shared corners meet on this grid

struct GridKey {
  std::int64_t x, y, z;
  bool operator==(const GridKey&) const = default;
};
struct GridHash {
  size_t operator()(const GridKey& k) const {
    return static_cast<size_t>(k.x * 73856093LL ^ k.y * 19349663LL ^ k.z * 83492791LL);
  }
};

// A child's triangle as it was before the weld: which child, its corners there.
struct SourceTriangle {
  std::uint32_t child = 0;
  std::array<std::uint32_t, 3> corner{};
};

// The welded surface being gathered: one vertex per 1 mm grid point; each welded triangle keeps its source.
struct Welded {
  std::vector<Eigen::Vector3f> positions;
  std::vector<std::uint32_t> indices;
  std::vector<SourceTriangle> sources;  // one per triangle of indices
  std::unordered_map<GridKey, std::uint32_t, GridHash> index_of;

  std::uint32_t vertex(const Eigen::Vector3f& p) {
    const GridKey key{std::llround(p.x() / kWeldStepM), std::llround(p.y() / kWeldStepM),
                      std::llround(p.z() / kWeldStepM)};
    auto [it, added] = index_of.emplace(key, static_cast<std::uint32_t>(positions.size()));
    if (added) positions.push_back(p);
    return it->second;
  }
  Eigen::Vector3d corner(size_t t, int k) const { return positions[indices[3 * t + k]].cast<double>(); }
};

Status gather(const Mesh& m, std::uint32_t child, Welded* w) {
  if (m.indices.size() % 3 != 0 || (!m.uvs.empty() && m.uvs.size() != m.positions.size()) ||
      (!m.colors.empty() && m.colors.size() != m.positions.size()))
    return make_error(ErrorCode::kInvalidInput, "inner tile: a child mesh is inconsistent");
  for (size_t t = 0; t + 2 < m.indices.size(); t += 3) {
    SourceTriangle src{child, {m.indices[t], m.indices[t + 1], m.indices[t + 2]}};
    std::array<std::uint32_t, 3> tri;
    for (int k = 0; k < 3; ++k) {
      if (src.corner[k] >= m.positions.size())
        return make_error(ErrorCode::kInvalidInput, "inner tile: index out of range");
      tri[k] = w->vertex(m.positions[src.corner[k]]);
    }
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) continue;  // collapsed by the weld
    w->indices.insert(w->indices.end(), tri.begin(), tri.end());
    w->sources.push_back(src);
  }
  return ok_status();
}

bool has_texture(const Mesh& m) { return !m.uvs.empty() && !m.texture.empty() && m.texture.channels == 3; }

// The side of the texels of each child and of all of them, metres: sqrt(world area / texel area) over their textured
// triangles (0 when none is textured); the last entry is all children's.
std::vector<double> children_texel_m(const Welded& w, const std::vector<const Mesh*>& children) {
  std::vector<double> world(children.size() + 1, 0.0), texels(children.size() + 1, 0.0);
  for (size_t t = 0; t < w.sources.size(); ++t) {
    const SourceTriangle& s = w.sources[t];
    const Mesh& m = *children[s.child];
    if (!has_texture(m)) continue;
    const double area = 0.5 * (w.corner(t, 1) - w.corner(t, 0)).cross(w.corner(t, 2) - w.corner(t, 0)).norm();
    const Eigen::Vector2d size(m.texture.width, m.texture.height);
    const Eigen::Vector2d a = m.uvs[s.corner[0]].cast<double>().cwiseProduct(size);
    const Eigen::Vector2d e1 = m.uvs[s.corner[1]].cast<double>().cwiseProduct(size) - a;
    const Eigen::Vector2d e2 = m.uvs[s.corner[2]].cast<double>().cwiseProduct(size) - a;
    const double texel_area = 0.5 * std::abs(e1.x() * e2.y() - e1.y() * e2.x());
    for (size_t i : {size_t{s.child}, children.size()}) world[i] += area, texels[i] += texel_area;
  }
  std::vector<double> side(world.size(), 0.0);
  for (size_t i = 0; i < side.size(); ++i) side[i] = texels[i] > 0.0 ? std::sqrt(world[i] / texels[i]) : 0.0;
  return side;
}

// The welded triangles in a bounding volume hierarchy (Eigen's KdBVH), for exact nearest-point queries by branch and
// bound (BVMinimize): a query visits only the volumes nearer than the best triangle found so far.
class SurfaceTree {
 public:
  // Over the first `triangles` welded triangles.
  SurfaceTree(const Welded& w, size_t triangles) : w_(w) {
    std::vector<std::uint32_t> ids(triangles);
    std::vector<Eigen::AlignedBox3d> boxes(ids.size());
    for (size_t t = 0; t < ids.size(); ++t) {
      ids[t] = static_cast<std::uint32_t>(t);
      for (int k = 0; k < 3; ++k) boxes[t].extend(w.corner(t, k));
    }
    tree_.init(ids.begin(), ids.end(), boxes.begin(), boxes.end());
  }

  // The welded triangle nearest to p (closest point on a triangle: Ericson, Real-Time Collision Detection, 5.1.5),
  // and its barycentric weights; of equally near ones, the same one for the same inputs. `hint`, when given, is a
  // triangle likely to be near (the previous texel's answer): its distance bounds the search from the start.
  std::uint32_t nearest(const Eigen::Vector3d& p, const std::uint32_t* hint, Eigen::Vector3d* weights) const {
    Search s{this, p};
    if (hint) s.minimumOnObject(*hint);
    Eigen::BVMinimize(tree_, s);
    *weights = s.weights;
    return s.best;
  }

  // The child triangle that the line p + s n (n unit) meets nearest to p within |s| <= max_s (texture baking's ray
  // cast along the low-resolution surface's normal), and the barycentric weights of the hit; false when none does.
  // Of equally near hits, the same one for the same inputs.
  bool along(const Eigen::Vector3d& p, const Eigen::Vector3d& n, double max_s, std::uint32_t* triangle,
             Eigen::Vector3d* weights) const {
    Cast c{this, p, n, max_s};
    Eigen::BVIntersect(tree_, c);
    if (!c.hit) return false;
    *triangle = c.best;
    *weights = c.weights;
    return true;
  }

  struct Hit {
    double s;  // signed distance along the line
    std::uint32_t triangle;
    Eigen::Vector3d weights;
  };
  // Every child triangle that the line p + s n (n unit) meets within |s| <= max_s, nearest first (ties: the lower
  // triangle), into *hits (cleared first).
  void all_along(const Eigen::Vector3d& p, const Eigen::Vector3d& n, double max_s, std::vector<Hit>* hits) const {
    hits->clear();
    CastAll c{{this, p, n, max_s}, hits};
    Eigen::BVIntersect(tree_, c);
    std::sort(hits->begin(), hits->end(), [](const Hit& a, const Hit& b) {
      return std::abs(a.s) != std::abs(b.s) ? std::abs(a.s) < std::abs(b.s) : a.triangle < b.triangle;
    });
  }

 private:
  // BVMinimize's minimizer: squared distances; a volume no nearer than the best so far returns infinity, which
  // BVMinimize never expands.
  struct Search {
    using Scalar = double;
    const SurfaceTree* tree;
    Eigen::Vector3d p;
    double best_d2 = INFINITY;
    std::uint32_t best = 0;
    Eigen::Vector3d weights = Eigen::Vector3d(1, 0, 0);
    double minimumOnVolume(const Eigen::AlignedBox3d& box) const {
      const double d2 = box.squaredExteriorDistance(p);
      return d2 > best_d2 ? INFINITY : d2;
    }
    double minimumOnObject(std::uint32_t t) {
      const Welded& w = tree->w_;
      const Eigen::Vector3d a = w.corner(t, 0), b = w.corner(t, 1), c = w.corner(t, 2);
      const Eigen::Vector3d bary = closest_weights(p, a, b, c);
      const double d2 = (bary.x() * a + bary.y() * b + bary.z() * c - p).squaredNorm();
      if (d2 < best_d2 || (d2 == best_d2 && t < best)) best_d2 = d2, best = t, weights = bary;
      return best_d2;
    }
  };

  // BVIntersect's intersector for along(): the segment shrinks to the nearest hit so far.
  struct Cast {
    const SurfaceTree* tree;
    Eigen::Vector3d p, n;
    double reach;  // |s| of the nearest hit so far, or max_s
    bool hit = false;
    std::uint32_t best = 0;
    Eigen::Vector3d weights = Eigen::Vector3d(1, 0, 0);
    bool intersectVolume(const Eigen::AlignedBox3d& box) const {  // slabs, s in [-reach, reach]
      double lo = -reach, hi = reach;
      for (int a = 0; a < 3; ++a) {
        if (std::abs(n[a]) < 1e-12) {
          if (p[a] < box.min()[a] || p[a] > box.max()[a]) return false;
          continue;
        }
        double s0 = (box.min()[a] - p[a]) / n[a], s1 = (box.max()[a] - p[a]) / n[a];
        if (s0 > s1) std::swap(s0, s1);
        lo = std::max(lo, s0);
        hi = std::min(hi, s1);
        if (lo > hi) return false;
      }
      return true;
    }
    // Moller-Trumbore, both sides: whether the line meets triangle t, where (signed s) and at which weights.
    bool meets(std::uint32_t t, double* s, Eigen::Vector3d* bary) const {
      const Welded& w = tree->w_;
      const Eigen::Vector3d a = w.corner(t, 0), e1 = w.corner(t, 1) - a, e2 = w.corner(t, 2) - a;
      const Eigen::Vector3d q = n.cross(e2);
      const double det = e1.dot(q);
      if (std::abs(det) < 1e-18) return false;  // the line runs along the triangle
      const Eigen::Vector3d d = p - a;
      const double u = d.dot(q) / det;
      if (u < 0.0 || u > 1.0) return false;
      const Eigen::Vector3d r = d.cross(e1);
      const double v = n.dot(r) / det;
      if (v < 0.0 || u + v > 1.0) return false;
      *s = e2.dot(r) / det;  // along n
      *bary = Eigen::Vector3d(1.0 - u - v, u, v);
      return true;
    }
    bool intersectObject(std::uint32_t t) {
      double s = 0.0;
      Eigen::Vector3d bary;
      if (!meets(t, &s, &bary)) return false;
      s = std::abs(s);
      if (s > reach || (hit && s == reach && t > best)) return false;
      reach = s, hit = true, best = t, weights = bary;
      return false;  // keep looking for a nearer one
    }
  };

  // BVIntersect's intersector for all_along(): the segment stays whole.
  struct CastAll {
    Cast line;
    std::vector<Hit>* hits;
    bool intersectVolume(const Eigen::AlignedBox3d& box) const { return line.intersectVolume(box); }
    bool intersectObject(std::uint32_t t) {
      double s = 0.0;
      Eigen::Vector3d bary;
      if (line.meets(t, &s, &bary) && std::abs(s) <= line.reach) hits->push_back({s, t, bary});
      return false;
    }
  };

  static Eigen::Vector3d closest_weights(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                         const Eigen::Vector3d& c) {
    const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
    const double d1 = ab.dot(ap), d2 = ac.dot(ap);
    if (d1 <= 0 && d2 <= 0) return {1, 0, 0};
    const Eigen::Vector3d bp = p - b;
    const double d3 = ab.dot(bp), d4 = ac.dot(bp);
    if (d3 >= 0 && d4 <= d3) return {0, 1, 0};
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) {
      const double v = d1 / (d1 - d3);
      return {1 - v, v, 0};
    }
    const Eigen::Vector3d cp = p - c;
    const double d5 = ab.dot(cp), d6 = ac.dot(cp);
    if (d6 >= 0 && d5 <= d6) return {0, 0, 1};
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) {
      const double w = d2 / (d2 - d6);
      return {1 - w, 0, w};
    }
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
      const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
      return {0, 1 - w, w};
    }
    const double denom = va + vb + vc;
    if (!(std::abs(denom) > 0)) return {1, 0, 0};  // a degenerate triangle: its first corner
    const double v = vb / denom, w = vc / denom;
    return {1 - v - w, v, w};
  }

  const Welded& w_;
  Eigen::KdBVH<double, 3, std::uint32_t> tree_;
};

// One layer where children overlap. Keyframes that saw the same place hold the same surface several times over,
// offset by depth noise and pose error; merged as they are, a coarse tile keeps every copy (on an explored floor, 12
// TUM keyframes a cell: a level-1 tile held 12 layers, and the level-1 tiles most of the hierarchy's bytes and
// build time). Children are taken in turn, finest texels first (ties: the later child, the newer keyframe), each
// whole: a child's triangle is dropped when its centroid lies in a voxel (voxel_m) that a child taken before it
// already covers with a surface facing the same way, so each place keeps the surface of the child that saw it best,
// in patches as large as that child covers (no mosaic of keyframes triangle by triangle), and a place only one child
// saw keeps that child's surface. "Facing the same way": a voxel is covered per dominant normal axis and sign, a
// kept triangle covering every such direction its normal leans toward (a component over 0.3), so a surface near 45
// degrees is not kept twice, and the two sides of a thin object are both kept. A kept triangle covers the voxels of
// points spread over it at half a voxel, and their neighbours along its dominant normal axis (a layer a few cm behind
// another, across a voxel border, is still the same surface). The welded triangles are reordered: the kept ones first
// (in their order), the dropped ones after them, which still give the kept surface its colours (colour_along). Returns
// the centroids of the dropped triangles: their distance to the kept surface (at most about 2.5 voxels by
// construction) is what dropping the copies costs.
struct VoxelKey {
  std::int64_t x, y, z;
  int facing;  // 2 * axis + (component < 0)
  bool operator==(const VoxelKey&) const = default;
};
struct VoxelHash {
  size_t operator()(const VoxelKey& k) const {
    return GridHash{}(GridKey{k.x, k.y, k.z}) ^ static_cast<size_t>(k.facing) * 2654435761u;
  }
};

int dominant_facing(const Eigen::Vector3d& n) {
  int axis = 0;
  n.cwiseAbs().maxCoeff(&axis);
  return 2 * axis + (n[axis] < 0);
}

std::vector<Eigen::Vector3d> keep_one_layer(Welded* w, const std::vector<double>& child_texel_m, double voxel_m) {
  const size_t n_children = child_texel_m.size() - 1;
  std::vector<std::uint32_t> order(n_children);
  for (size_t c = 0; c < n_children; ++c) order[c] = static_cast<std::uint32_t>(c);
  const auto rank = [&](std::uint32_t c) { return child_texel_m[c] > 0.0 ? child_texel_m[c] : INFINITY; };
  std::sort(order.begin(), order.end(),
            [&](std::uint32_t a, std::uint32_t b) { return rank(a) != rank(b) ? rank(a) < rank(b) : a > b; });
  std::vector<std::vector<std::uint32_t>> by_child(n_children);
  for (size_t t = 0; t < w->sources.size(); ++t) by_child[w->sources[t].child].push_back(static_cast<std::uint32_t>(t));
  const auto voxel = [&](const Eigen::Vector3d& p, int facing) {
    return VoxelKey{static_cast<std::int64_t>(std::floor(p.x() / voxel_m)),
                    static_cast<std::int64_t>(std::floor(p.y() / voxel_m)),
                    static_cast<std::int64_t>(std::floor(p.z() / voxel_m)), facing};
  };
  std::unordered_set<VoxelKey, VoxelHash> covered;
  std::vector<char> keep(w->sources.size(), 1);
  for (std::uint32_t c : order) {
    for (std::uint32_t t : by_child[c]) {
      const Eigen::Vector3d a = w->corner(t, 0), b = w->corner(t, 1), d = w->corner(t, 2);
      const Eigen::Vector3d n = (b - a).cross(d - a);
      if (!(n.squaredNorm() > 0.0)) continue;
      keep[t] = !covered.count(voxel((a + b + d) / 3.0, dominant_facing(n)));
    }
    for (std::uint32_t t : by_child[c]) {
      if (!keep[t]) continue;
      const Eigen::Vector3d a = w->corner(t, 0), e1 = w->corner(t, 1) - a, e2 = w->corner(t, 2) - a;
      const Eigen::Vector3d n = e1.cross(e2).normalized();
      if (!n.allFinite()) continue;
      int axis = 0;
      n.cwiseAbs().maxCoeff(&axis);
      const double longest = std::max({e1.norm(), e2.norm(), (e2 - e1).norm()});
      const int steps = std::max(1, static_cast<int>(std::ceil(longest / (0.5 * voxel_m))));
      for (int i = 0; i <= steps; ++i)
        for (int j = 0; i + j <= steps; ++j) {
          const Eigen::Vector3d p = a + (double(i) / steps) * e1 + (double(j) / steps) * e2;
          for (int f = 0; f < 6; ++f) {
            const double along = (f % 2 ? -1.0 : 1.0) * n[f / 2];
            if (along <= 0.3) continue;
            const VoxelKey k = voxel(p, f);
            for (std::int64_t s = -1; s <= 1; ++s) {
              VoxelKey m = k;
              (axis == 0 ? m.x : axis == 1 ? m.y : m.z) += s;
              covered.insert(m);
            }
          }
        }
    }
  }
  std::vector<Eigen::Vector3d> dropped;
  std::vector<std::uint32_t> indices;
  std::vector<SourceTriangle> sources;
  indices.reserve(w->indices.size());
  sources.reserve(w->sources.size());
  for (char pass : {1, 0})
    for (size_t t = 0; t < keep.size(); ++t) {
      if (keep[t] != pass) continue;
      indices.insert(indices.end(), w->indices.begin() + 3 * t, w->indices.begin() + 3 * t + 3);
      sources.push_back(w->sources[t]);
      if (!pass) dropped.push_back((w->corner(t, 0) + w->corner(t, 1) + w->corner(t, 2)) / 3.0);
    }
  w->indices.swap(indices);
  w->sources.swap(sources);
  return dropped;
}

// The largest distance from `points` to `surface`, metres.
double largest_distance(const SurfaceTree& surface, const Welded& w, const std::vector<Eigen::Vector3d>& points) {
  double out = 0.0;
  std::uint32_t hint = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    Eigen::Vector3d bary;
    hint = surface.nearest(points[i], i ? &hint : nullptr, &bary);
    const Eigen::Vector3d q =
        bary.x() * w.corner(hint, 0) + bary.y() * w.corner(hint, 1) + bary.z() * w.corner(hint, 2);
    out = std::max(out, (q - points[i]).norm());
  }
  return out;
}

// The colour of the children's surface at welded triangle t, barycentric weights `bary`: its child's texture
// (bilinear at the interpolated UV), else its colours, else grey.
void source_colour(const Welded& w, const std::vector<const Mesh*>& children, const std::vector<CellSource>& textures,
                   std::uint32_t t, const Eigen::Vector3d& bary, std::uint8_t* rgb) {
  const SourceTriangle& s = w.sources[t];
  const Mesh& m = *children[s.child];
  if (textures[s.child].data) {
    Eigen::Vector2d uv = Eigen::Vector2d::Zero();
    for (int k = 0; k < 3; ++k) uv += bary[k] * m.uvs[s.corner[k]].cast<double>();
    const CellSource& src = textures[s.child];
    sample_bilinear_rgb(src, uv.x() * src.cols - 0.5, uv.y() * src.rows - 0.5, rgb);
  } else if (!m.colors.empty()) {
    for (int c = 0; c < 3; ++c) {
      double v = 0.0;
      for (int k = 0; k < 3; ++k) v += bary[k] * m.colors[s.corner[k]][c];
      rgb[c] = static_cast<std::uint8_t>(std::clamp(std::lround(v), 0L, 255L));
    }
  } else {
    rgb[0] = rgb[1] = rgb[2] = 128;
  }
}

// The children's colour where the line p + s n (n unit) meets their surface within |s| <= reach_m; false when it meets
// none. With layer_m = 0, the nearest hit's colour. With layer_m > 0, the mean over every hit within layer_m of the
// nearest one whose triangle faces the same way: the layers of the keyframes that saw the place, their exposures
// averaged as the surfaces themselves would be seen through each other (the two sides of a thin object stay apart).
// *triangle is the nearest hit.
bool colour_along(const Welded& w, const std::vector<const Mesh*>& children, const std::vector<CellSource>& textures,
                  const SurfaceTree& tree, const Eigen::Vector3d& p, const Eigen::Vector3d& n, double reach_m,
                  double layer_m, std::vector<SurfaceTree::Hit>* hits, std::uint32_t* triangle, std::uint8_t* rgb) {
  Eigen::Vector3d bary;
  if (layer_m <= 0.0) {
    if (!tree.along(p, n, reach_m, triangle, &bary)) return false;
    source_colour(w, children, textures, *triangle, bary, rgb);
    return true;
  }
  tree.all_along(p, n, reach_m, hits);
  if (hits->empty()) return false;
  const auto facing = [&](std::uint32_t t) {
    return (w.corner(t, 1) - w.corner(t, 0)).cross(w.corner(t, 2) - w.corner(t, 0)).dot(n) >= 0.0;
  };
  const SurfaceTree::Hit& first = hits->front();
  const bool side = facing(first.triangle);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  int count = 0;
  for (const SurfaceTree::Hit& h : *hits) {
    if (std::abs(h.s - first.s) > layer_m || facing(h.triangle) != side) continue;
    std::uint8_t c[3];
    source_colour(w, children, textures, h.triangle, h.weights, c);
    sum += Eigen::Vector3d(c[0], c[1], c[2]);
    ++count;
  }
  for (int c = 0; c < 3; ++c) rgb[c] = static_cast<std::uint8_t>(std::clamp(std::lround(sum[c] / count), 0L, 255L));
  *triangle = first.triangle;
  return true;
}

// The median, over the simplified triangles, of the leg (in texels of texel_m) of a right isosceles triangle of the
// same area: how big their atlas cells would be.
double median_leg_texels(const Welded& w, const std::vector<std::uint32_t>& simplified, double texel_m) {
  std::vector<double> legs(simplified.size() / 3);
  for (size_t t = 0; t < legs.size(); ++t) {
    const Eigen::Vector3d a = w.positions[simplified[3 * t]].cast<double>();
    const Eigen::Vector3d b = w.positions[simplified[3 * t + 1]].cast<double>();
    const Eigen::Vector3d c = w.positions[simplified[3 * t + 2]].cast<double>();
    legs[t] = std::sqrt((b - a).cross(c - a).norm()) / texel_m;  // area = leg^2 / 2
  }
  std::nth_element(legs.begin(), legs.begin() + legs.size() / 2, legs.end());
  return legs[legs.size() / 2];
}

// The simplified triangles as a vertex-coloured mesh, their vertices shared as the simplifier left them. A vertex's
// colour is the mean of the children's at a point a fifth of the way from it toward the far side of each triangle
// around it: the surface around the vertex, not one point of it. With layer_m > 0 that point's colour is
// colour_along's, along the triangle's normal, where the line meets the children within reach_m; else (or where it
// meets none) the nearest point's.
Mesh vertex_coloured(const Welded& w, const std::vector<std::uint32_t>& simplified,
                     const std::vector<const Mesh*>& children, const std::vector<CellSource>& textures,
                     const SurfaceTree& surface, double layer_m, double reach_m) {
  Mesh m;
  std::vector<std::uint32_t> remap(w.positions.size(), UINT32_MAX);
  for (std::uint32_t v : simplified)
    if (remap[v] == UINT32_MAX) {
      remap[v] = static_cast<std::uint32_t>(m.positions.size());
      m.positions.push_back(w.positions[v]);
    }
  std::vector<Eigen::Vector3d> sum(m.positions.size(), Eigen::Vector3d::Zero());
  std::vector<int> count(m.positions.size(), 0);
  m.indices.resize(simplified.size());
  std::vector<SurfaceTree::Hit> hits;
  for (size_t t = 0; t < simplified.size() / 3; ++t) {
    const auto corner = [&](int k) { return w.positions[simplified[3 * t + k % 3]].cast<double>(); };
    const Eigen::Vector3d normal = (corner(1) - corner(0)).cross(corner(2) - corner(0)).normalized();
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = remap[simplified[3 * t + k]];
      m.indices[3 * t + k] = v;
      const Eigen::Vector3d p = 0.8 * corner(k) + 0.1 * corner(k + 1) + 0.1 * corner(k + 2);
      std::uint8_t rgb[3];
      std::uint32_t source = 0;
      if (layer_m <= 0.0 || !normal.allFinite() ||
          !colour_along(w, children, textures, surface, p, normal, reach_m, layer_m, &hits, &source, rgb)) {
        Eigen::Vector3d bary;
        source = surface.nearest(p, nullptr, &bary);
        source_colour(w, children, textures, source, bary, rgb);
      }
      sum[v] += Eigen::Vector3d(rgb[0], rgb[1], rgb[2]);
      ++count[v];
    }
  }
  m.colors.resize(m.positions.size());
  for (size_t v = 0; v < m.positions.size(); ++v)
    for (int c = 0; c < 3; ++c)
      m.colors[v][c] = static_cast<std::uint8_t>(std::clamp(std::lround(sum[v][c] / count[v]), 0L, 255L));
  return m;
}

// Edge collapses (meshopt_simplify) keep the topology, and merged keyframes are thousands of pieces with open borders
// and holes: at the top levels the collapses stall (5,000 keyframes: a level-6 tile kept 110,378 of its 112,918
// triangles against a target of 20,000, and 1.7 MB). Beyond this many times the target, the tile is simplified by
// vertex clustering instead (meshopt_simplifySloppy), which reaches it.
constexpr double kStalledRatio = 1.5;

// The first `triangles` welded triangles clustered down to about `target` triangles (their indices; more clusters
// where meshoptimizer's estimate of the error would pass relative_limit), and in *error_m the farthest welded vertex
// of theirs from the clustered surface, metres: the clustering's error, measured rather than taken from
// meshoptimizer, whose estimate for the sloppy simplifier is not a distance bound.
std::vector<std::uint32_t> cluster(const Welded& w, size_t triangles, size_t target, float relative_limit,
                                   double* error_m) {
  Welded clustered;
  clustered.indices.resize(3 * triangles);
  const size_t n =
      meshopt_simplifySloppy(clustered.indices.data(), w.indices.data(), 3 * triangles, &w.positions[0].x(),
                             w.positions.size(), sizeof(Eigen::Vector3f), 3 * target, relative_limit, nullptr);
  clustered.indices.resize(n);
  if (n == 0) return {};
  clustered.positions = w.positions;
  std::vector<char> used(w.positions.size(), 0);
  for (size_t i = 0; i < 3 * triangles; ++i) used[w.indices[i]] = 1;
  std::vector<Eigen::Vector3d> points;
  for (size_t v = 0; v < used.size(); ++v)
    if (used[v]) points.push_back(w.positions[v].cast<double>());
  *error_m = largest_distance(SurfaceTree(clustered, n / 3), clustered, points);
  return std::move(clustered.indices);
}

// A simplified triangle's cell: the corner with the largest angle first, legs of side / texel_m texels.
BakeTriangle bake_triangle(const std::array<Eigen::Vector3d, 3>& v, double texel_m) {
  // The triangle in its own plane (an isometry), in texels.
  const Eigen::Vector3d e1 = v[1] - v[0], e2 = v[2] - v[0];
  const double l1 = e1.norm();
  const Eigen::Vector3d x = l1 > 0 ? Eigen::Vector3d(e1 / l1) : Eigen::Vector3d::UnitX();
  const double along = e2.dot(x), across = (e2 - along * x).norm();
  const std::array<Eigen::Vector2d, 3> plane = {Eigen::Vector2d(0, 0), Eigen::Vector2d(l1 / texel_m, 0),
                                                Eigen::Vector2d(along / texel_m, across / texel_m)};
  int right = 0;
  BakeTriangle t;
  t.leg = footprint_leg_class(footprint_leg_px(plane, &right));
  for (int k = 0; k < 3; ++k) t.world[k] = v[(right + k) % 3];
  return t;
}

}  // namespace

Result<InnerTile> build_inner(const std::vector<const Mesh*>& children, double children_error_m,
                              const SimplifyTarget& goal, const InnerBakeOptions& options) {
  Welded w;
  for (size_t c = 0; c < children.size(); ++c)
    if (auto st = gather(*children[c], static_cast<std::uint32_t>(c), &w); !st) return st.error();
  if (w.indices.empty()) return make_error(ErrorCode::kEmpty, "inner tile: the children hold no triangle");
  InnerTile out;
  out.merged_triangles = w.indices.size() / 3;
  const std::vector<double> texel_side = children_texel_m(w, children);
  std::vector<Eigen::Vector3d> dropped;
  const double layer_voxel_m = std::max(options.min_layer_voxel_m, children_error_m);
  if (children.size() > 1 && options.min_layer_voxel_m > 0.0) dropped = keep_one_layer(&w, texel_side, layer_voxel_m);
  out.kept_triangles = out.merged_triangles - dropped.size();
  // Where layers were dropped, the colours are their mean along each texel's line (colour_along).
  const double layer_m = dropped.empty() ? 0.0 : layer_voxel_m;
  // A level up halves the detail along each floor axis: a quarter of the triangles, at most target_triangles.
  const size_t target = std::max<size_t>(1, std::min(goal.triangles, (out.kept_triangles + 3) / 4));
  std::vector<std::uint32_t> simplified(3 * out.kept_triangles);
  float relative_error = 0.0f;
  const float scale = meshopt_simplifyScale(&w.positions[0].x(), w.positions.size(), sizeof(Eigen::Vector3f));
  // meshoptimizer's limit is relative to the extent; above 1 it never binds.
  const float limit = scale > 0.0f ? static_cast<float>(std::min(1.0, goal.max_error_m / scale)) : 1.0f;
  const size_t kept = meshopt_simplify(simplified.data(), w.indices.data(), 3 * out.kept_triangles, &w.positions[0].x(),
                                       w.positions.size(), sizeof(Eigen::Vector3f), 3 * target, limit,
                                       goal.lock_border ? unsigned(meshopt_SimplifyLockBorder) : 0u, &relative_error);
  simplified.resize(kept);
  out.simplify_error_m = static_cast<double>(relative_error) * scale;
  // Stalled, or stopped by the limit, far from the target: clustering is kept when it leaves fewer triangles within
  // the limit (or within the collapses' own error, when that is above it).
  if (!goal.lock_border && kept > kStalledRatio * 3 * target) {
    double clustered_error_m = 0.0;
    auto clustered = cluster(w, out.kept_triangles, target, limit, &clustered_error_m);
    // On a few dozen triangles the clustering's grid can leave far fewer than asked (40 to 2, at 1.7 m of error).
    if (clustered.size() >= 3 * std::max<size_t>(1, target / 2) && clustered.size() < simplified.size() &&
        clustered_error_m <= std::max(goal.max_error_m, out.simplify_error_m)) {
      out.clustered = true;
      out.simplify_error_m = clustered_error_m;
      simplified = std::move(clustered);
    }
  }
  if (simplified.empty()) {  // a few scattered triangles collapse to nothing: the tile keeps them as they are, since
                             // a tile left empty would take its branch, and the keyframes under it, out of the tileset
    simplified.assign(w.indices.begin(), w.indices.begin() + 3 * out.kept_triangles);
    out.simplify_error_m = 0.0;
    out.clustered = false;
  }

  const SurfaceTree surface(w, out.kept_triangles);
  out.layer_error_m = largest_distance(surface, w, dropped);
  std::optional<SurfaceTree> every_layer;
  if (!dropped.empty()) every_layer.emplace(w, w.sources.size());
  const SurfaceTree& colours = dropped.empty() ? surface : *every_layer;
  // A level up halves the detail along each axis, as for the triangles: texels at least twice the children's side,
  // so an inner tile holds about as many texels as one child, whatever its level. The texels follow the error of the
  // surface's detail (the children's and the simplifier's), not the layer choice's: the kept layer is textured as
  // finely as all the layers would have been (4 TUM keyframes at 0.05 m, a 64 px view of level-1 tiles against full
  // detail: 18.1 dB from the robot's pose and 22.3 dB from above, against 16.1 and 20.8 with the layer error in).
  const double detail_error_m = children_error_m + out.simplify_error_m;
  const double texel_m = std::max({detail_error_m / options.texels_per_error, 2.0 * texel_side.back(), kWeldStepM});
  std::vector<CellSource> textures(children.size());
  for (size_t c = 0; c < children.size(); ++c)
    if (has_texture(*children[c])) textures[c] = cell_source(children[c]->texture);
  // Each texel takes the children's surface where the simplified triangle's normal through it meets them nearest
  // (within the simplifier's error and two texels, and a layer's thickness where layers were dropped), as texture
  // bakers cast rays from a low-resolution mesh: a line crosses a few layers of a surface where a sphere of the same
  // radius would hold thousands of its triangles. A texel whose line meets nothing (beyond a silhouette) takes the
  // nearest point, searched from its neighbour's answer.
  const double reach_m = out.simplify_error_m + 2.0 * texel_m + layer_m;
  if (median_leg_texels(w, simplified, texel_m) < options.min_leg_texels) {
    out.mesh = vertex_coloured(w, simplified, children, textures, colours, layer_m, reach_m);
    return out;
  }
  std::vector<BakeTriangle> tris(simplified.size() / 3);
  for (size_t i = 0; i < tris.size(); ++i)
    tris[i] =
        bake_triangle({w.positions[simplified[3 * i]].cast<double>(), w.positions[simplified[3 * i + 1]].cast<double>(),
                       w.positions[simplified[3 * i + 2]].cast<double>()},
                      texel_m);
  auto mesh = bake_atlas_mesh(
      tris, options.atlas,
      [&](size_t i, const FootprintSlot& slot, const std::array<Eigen::Vector2d, 3>& corners, Image* atlas,
          std::uint8_t* sampled) {
        const BakeTriangle& t = tris[i];
        Eigen::Matrix3d A, W;
        for (int k = 0; k < 3; ++k) {
          A.col(k) << corners[k], 1.0;
          W.col(k) = t.world[k];
        }
        const Eigen::Matrix3d world_from_atlas = W * A.inverse();  // barycentric weights of the texel, then the point
        const Eigen::Vector3d normal = (t.world[1] - t.world[0]).cross(t.world[2] - t.world[0]).normalized();
        const bool flat = normal.allFinite();
        bool have_hint = false;
        std::uint32_t hint = 0;
        std::vector<SurfaceTree::Hit> hits;
        fill_cell_texels(slot, atlas, sampled, [&](double x, double y, std::uint8_t* rgb) {
          const Eigen::Vector3d p = world_from_atlas * Eigen::Vector3d(x, y, 1.0);
          if (!flat || !colour_along(w, children, textures, colours, p, normal, reach_m, layer_m, &hits, &hint, rgb)) {
            Eigen::Vector3d bary;
            hint = colours.nearest(p, have_hint ? &hint : nullptr, &bary);
            source_colour(w, children, textures, hint, bary, rgb);
          }
          have_hint = true;
        });
      });
  if (!mesh) return make_error(mesh.error().code, "inner tile: " + mesh.error().message);
  out.mesh = std::move(*mesh);
  return out;
}

}  // namespace rgbdcast::tiles
