#pragma once
// What one tile draws, built from what it covers:
// - a leaf: one keyframe's surface, whole, as its GLB shows it (its texture bytes kept), placed in the world. Leaves
//   are not split at cell borders, so they never crack: every triangle is in exactly one leaf, and a leaf is built
//   once per keyframe revision, whatever else the mission holds (no leaf grows with revisits, and storing the leaves
//   costs about the posted bytes). A leaf's cell (tiles/tile_key.h) is where its surface's centroid lies; its
//   bounding volume is its own.
// - an inner tile: the merged surface of its children, welded on a 1 mm grid and simplified with meshoptimizer
//   (meshopt_simplify), or, where those edge collapses stall (pieces that meet only at corners: the top of a long
//   mission's hierarchy), by vertex clustering (meshopt_simplifySloppy), whose error is measured: the farthest merged
//   vertex from the clustered surface. Its error is the simplifier's, in metres, plus the largest of its children's.
//   Open borders are not locked (a depth mesh is mostly border: locked, a level-2 tile kept 4x what it should; and the
//   leaves, whole keyframes, overlap rather than meet at cell borders), so a gap between two inner tiles is within
//   their geometric error, which is what a client's screen-space error bounds. Its texture is baked into one footprint
//   atlas at the resolution its error needs: texel side = error / InnerBakeOptions::texels_per_error, and at least
//   twice the children's own texel side (a level up halves the detail along each axis, as for the triangles, so a
//   tile's texel count does not grow with its level), legs halved until the atlas fits its cap. Colour comes from the
//   children's surface, not from the simplified one: each texel's point on a simplified triangle is projected along
//   that triangle's normal onto the children's (welded) triangles, the nearest hit within the simplifier's error plus
//   two texels (a texture baker's ray cast from the low-resolution surface), or where the line meets none (beyond a
//   silhouette) onto their nearest point; that triangle's texture (bilinear, at the barycentric UV) or colours give it.
//   A coarse tile whose triangles would be only a few texels across is vertex-coloured instead
//   (InnerBakeOptions::min_leg_texels), each vertex the mean colour of the surface around it. Simplification moves no
//   vertex (either simplifier keeps a subset), but one simplified triangle spans many children's triangles, their cells
//   and textures; the projection finds whichever of them lies under it (a bounding volume hierarchy over the children's
//   triangles), and where two layers overlap (keyframes seen twice) it takes the nearer one.
// A tile GLB holds one SceneNode. An inner tile's positions are metres in the mission's world frame (scene/camera.h),
// its node's to_world identity; a leaf keeps its keyframe's node: positions in the keyframe's frame, to_world its pose
// (the geometry encodes as compactly as the keyframe GLB did).
#include <cmath>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
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
  // A tile whose simplified triangles' median leg is shorter than this many texels is vertex-coloured instead: its
  // atlas would be mostly gutter (a cell of an n-texel leg is n + 4 texels square), and its unshared cell corners
  // take 4x the geometry bytes of shared vertices. On 12 TUM keyframes: levels 3 and up, the tiles 2.70x the posted
  // bytes (3.11x all textured); at 4, level 1 too: 1.54x, but the level-1 tiles fall from 19.6-20.5 dB to 16.1-16.3
  // dB against their leaves, and they are what a default overview draws beyond 10 m.
  double min_leg_texels = 3.0;
  // When > 0: where children overlap, one layer's geometry is kept (the surface of the child with the finest
  // texels), decided per voxel of this side or of the children's error, whichever is larger: layers nearer than about
  // a voxel are one surface. Its texels take the mean colour of every layer along their line. Off by default: on 12
  // TUM keyframes at 0.05 the tiles take 2.09x the posted bytes instead of 2.70x, but the level-1 tiles score
  // 16.7-19.6 dB against their leaves (each leaf compared at its own centroids) instead of 19.6-20.2: the keyframes'
  // surfaces disagree by their pose and depth errors, which one layer cannot follow. In images (4 keyframes, a 64 px
  // view of level-1 tiles against full detail) it loses from the robot's pose (18.1 dB against 19.5) and wins from
  // above (22.3 against 21.9).
  double min_layer_voxel_m = 0.0;
};

// The leaf that holds a placed keyframe (its nodes' to_world applied): the level-0 cell where the mean of its
// triangles' centroids lies, with keyframe = seq. nullopt when it has no triangle.
std::optional<TileKey> keyframe_leaf(const Scene& placed, std::int64_t seq, double leaf_size_m);

// A leaf's content, the placed keyframe's whole surface. A keyframe with one meshed node (what the reduction makes) is
// that node as it is: triangles, uvs and stored texture bytes in its own frame, placed by its to_world; several
// meshed nodes are baked into one footprint atlas in world coordinates. kEmpty when it has no triangle; kInvalidInput
// for a mesh whose indices, uvs or colours are inconsistent. `name` names the leaf in errors.
Result<SceneNode> build_leaf(const Scene& placed, const std::string& name, const LeafBakeOptions& options);

struct InnerTile {
  Mesh mesh;                      // textured (tiles/tile_bake.h), world coordinates
  double simplify_error_m = 0.0;  // the simplifier's error on the merged children, metres
  double layer_error_m = 0.0;     // what keeping one layer where children overlap moved the surface, metres
  size_t merged_triangles = 0;    // the children's
  size_t kept_triangles = 0;      // of those, in the one layer kept (what is simplified)
  bool clustered = false;         // edge collapses stalled: simplified by vertex clustering (its error measured)
};

// How far an inner tile is simplified: toward a quarter of its children's triangles and at most `triangles` (> 0),
// stopping where the edge collapses' error would pass max_error_m (metres; infinity: no limit). Where they stall
// (see build_inner), vertex clustering follows meshoptimizer's estimate of that limit, and the tile's error is the
// clustering's, measured.
struct SimplifyTarget {
  size_t triangles = 20000;
  double max_error_m = INFINITY;
  bool lock_border = false;
};

// An inner tile's content from its children's decoded contents (tile GLBs, world coordinates; textured or
// vertex-coloured) whose largest geometric error is children_error_m.
// kEmpty when the children hold no triangle; kInvalidInput for an inconsistent child mesh.
Result<InnerTile> build_inner(const std::vector<const Mesh*>& children, double children_error_m,
                              const SimplifyTarget& target, const InnerBakeOptions& options);

// The box of a mesh's positions (world), grown by pad_m on every side.
Eigen::AlignedBox3d mesh_box(const Mesh& mesh, double pad_m);

}  // namespace rgbdcast::tiles
