#pragma once
// What one tile draws, built from what it covers:
// - a leaf: the keyframes' own triangles whose centroid falls in its cell, whole (not split at the cell border, so
//   neighbouring leaves meet without a crack: a triangle is in exactly one leaf, and the leaf's bounding volume grows
//   to hold it). Its texture is baked into one footprint atlas (atlas/footprint_layout.h: a cell per triangle, about
//   one texel per source texel along each leg) from the keyframes' own textures, through each triangle's UVs: an
//   affine copy of what the keyframe GLB shows, whichever keyframes the leaf merges.
// - an inner tile: the merged surface of its children, welded on a 1 mm grid and simplified with meshoptimizer
//   (meshopt_simplify). Its error is the simplifier's, in metres, plus the largest of its children's. At level 1 open
//   borders are locked, so the finest inner tiles meet their neighbours exactly; above it they are not (a depth mesh
//   is mostly border: locked, a level-2 tile kept 4x what it should), and a gap between two coarse tiles is within
//   their geometric error, which is what a client's screen-space error bounds. Its texture is baked into one
//   footprint atlas at the resolution its error needs: texel side = error / InnerBakeOptions::texels_per_error, and at
//   least twice the children's own texel side (a level up halves the detail along each axis, as for the triangles, so
//   a tile's texel count does not grow with its level), legs halved until the atlas fits its cap. Colour comes
//   from the children's surface, not from the simplified one: each texel's point on a simplified triangle is
//   projected along that triangle's normal onto the children's (welded) triangles, the nearest hit within the
//   simplifier's error plus two texels (a texture baker's ray cast from the low-resolution surface), or where the
//   line meets none (beyond a silhouette) onto their nearest point; that triangle's texture (bilinear, at the
//   barycentric UV) or colours give it. Simplification moves no vertex (meshopt_simplify keeps a subset), but one
//   simplified triangle spans many children's triangles, their cells and textures; the projection finds whichever of
//   them lies under it (a bounding volume hierarchy over the children's triangles), and where two layers overlap
//   (keyframes seen twice) it takes the nearer one.
// Positions are metres in the mission's world frame (scene/camera.h); the tile's one SceneNode has to_world identity.
#include <cstdint>
#include <functional>
#include <vector>

#include <Eigen/Geometry>

#include "scene/result.h"
#include "scene/scene.h"
#include "tiles/tile_key.h"

namespace rgbdcast::tiles {

// A tile's footprint atlas (tiles/tile_bake.h).
struct BakeOptions {
  int max_atlas_side_px = 4096;  // legs are halved until the atlas fits
  int gutter_px = 1;
  // Above the keyframes' own (the budgeted realtime preset encodes at q45-67); on 4 TUM keyframes q75 against q85
  // takes the leaves from 225 kB to 197 kB and the whole hierarchy from 8.7x to 6.8x the posted keyframe bytes.
  int jpeg_quality = 75;
};
using LeafBakeOptions = BakeOptions;

struct InnerBakeOptions {
  BakeOptions atlas{2048, 1, 75};
  // Texels per metre of geometric error along a cell's legs: at a client's default screen-space error of 16 px, a
  // tile shown at the distance where its error is 16 px draws a texel over about 8 px, as blurred as its geometry is
  // coarse (4 TUM keyframes: the level-1 textures are 32 kB at 2 and q75, 82 kB at 4 and q85).
  double texels_per_error = 2.0;
};

// The triangles of a placed keyframe (its nodes' to_world applied) whose centroid lies in the leaf `key`, as pairs
// (node index, triangle index), in node then triangle order.
std::vector<std::pair<std::uint32_t, std::uint32_t>> leaf_triangles(const Scene& placed, const TileKey& key,
                                                                     double leaf_size_m);
// The leaves (level 0) that some triangle of the placed keyframe falls in, in key order.
std::vector<TileKey> leaves_touched(const Scene& placed, double leaf_size_m);

// A leaf's content from the given placed keyframes (in the order given; each contributes the triangles leaf_triangles
// names): one textured mesh in world coordinates, its triangles in input order. kEmpty when no triangle falls in
// the leaf; kInvalidInput for a mesh whose indices or uvs are inconsistent.
Result<Mesh> build_leaf(const std::vector<const Scene*>& keyframes, const TileKey& key, double leaf_size_m,
                        const LeafBakeOptions& options);

struct InnerTile {
  Mesh mesh;               // textured (tiles/tile_bake.h), world coordinates
  double simplify_error_m = 0.0;  // the simplifier's error on the merged children, metres
  size_t merged_triangles = 0;    // before simplification
};

// An inner tile's content from its children's decoded contents (tile GLBs, world coordinates; textured or
// vertex-coloured) whose largest geometric error is children_error_m. target_triangles > 0.
// kEmpty when the children hold no triangle; kInvalidInput for an inconsistent child mesh.
Result<InnerTile> build_inner(const std::vector<const Mesh*>& children, double children_error_m,
                              size_t target_triangles, bool lock_border, const InnerBakeOptions& options);

// The box of a mesh's positions (world), grown by pad_m on every side.
Eigen::AlignedBox3d mesh_box(const Mesh& mesh, double pad_m);

}  // namespace rgbdcast::tiles
