#pragma once
// Texturing a reduced mesh from its colour frame (paper, section 3.3), in one of three modes:
//  - kAtlas: every triangle gets its own undistorted texture in a square cell of an atlas (see atlas_layout.h and
//    triangle_homography.h); the output mesh gives each triangle its own three vertices (positions duplicated) with
//    UVs at its cell's corners.
//  - kFrame: the baseline: the whole colour frame is the texture and each vertex's UV is its projected pixel
//    (projective texturing, affine across each triangle, so large oblique triangles are distorted). Shared vertices
//    are kept (reordered for compression when reorder_triangles; vertices no triangle uses are dropped).
//  - kFootprint: the undistorted atlas with cells sized to each triangle's footprint in the colour image (about one
//    texel per source pixel along each leg, AtlasOptions::texels_per_px), two triangles of a size class per cell
//    (triangles sharing their hypotenuse share it without a gutter), shelf-packed into one image
//    (footprint_layout.h). Triangles whose frame-texture mapping is already within footprint_patch_deviation_px of
//    the projective one (small or facing the camera) are textured from 1:1 patches of the frame packed in the same
//    image instead. Texels no triangle samples are filled smoothly (unsampled_fill.h) so JPEG spends almost nothing
//    on them. Every triangle's texture is within 0.5 px of its projection (cells: exact up to rounding; patches: the
//    deviation bound). Meant for the realtime preset's right-triangulated depth image. Output mesh: cell triangles
//    have their own three vertices (as kAtlas) with UVs on texel corners; the triangles of one patch share their
//    vertices, with UVs on texel centres (vertices at pixel centres).
// Input: mesh positions in the camera frame of color_rgb (CV_8UC3, RGB order) which is already undistorted, so
// `pinhole` must be the pinhole intrinsics (distortion ignored) of that image. Triangles with a vertex at z <= 0 or
// no area are dropped (counted). The texture is returned as pixels (Mesh::texture, RGB8) and JPEG-encoded
// (Mesh::texture_encoded, texture_mime "image/jpeg").
#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "scene/intrinsics.h"
#include "scene/mesh.h"
#include "scene/result.h"

namespace rgbdcast {

// kAuto picks per frame: the atlas when the mesh's median triangle covers more source pixels than a cell gives it
// (undistortion then matters), else the frame texture (tiny triangles: projective texturing is exact to a pixel and
// the frame costs far fewer bytes; see BENCHMARKS.md). AtlasResult::mode says which was used.
// kAuto chooses between kAtlas and kFrame only.
enum class TextureMode { kAtlas, kFrame, kAuto, kFootprint };
const char* to_string(TextureMode mode);
// "atlas", "frame", "auto" or "footprint"; anything else is kInvalidArgument.
Result<TextureMode> parse_texture_mode(const std::string& name);

struct AtlasOptions {
  TextureMode mode = TextureMode::kAtlas;
  int cell_size_px = 8;      // side of a square cell (texels); 8 aligns cells with JPEG blocks
  int gutter_px = 1;         // texels kept free around each triangle (filled from the triangle's own plane)
  bool two_per_cell = true;  // upper + lower triangle per cell (halves the atlas)
  int jpeg_quality = 85;     // 1..100
  // meshoptimizer vertex-cache order: neighbouring triangles in neighbouring cells. Unset: on for kAtlas and kFrame;
  // off for kFootprint, where it costs ~2/3 of the build for nothing (TUM, 22.8k triangles: JPEG q85 56449 B with it,
  // 56383 B without; an RTIN's own order is local already).
  std::optional<bool> reorder_triangles;
  int max_atlas_side_px = 8192;
  // kFootprint: texels per source pixel along a triangle's legs (cells are rounded up to the next size class; frame
  // patches are always 1:1).
  double texels_per_px = 1.0;
  // kFootprint: two triangles that share their hypotenuse share one cell without a gutter between them (a "diamond",
  // footprint_layout.h): about a third fewer texels on a right-triangulated depth image, and no seam inside the cell.
  bool footprint_diamonds = true;
  // kFootprint: triangles whose affine (frame-texture) mapping is within this many pixels of the projective one, and
  // that fit a tile, are textured from patches of the colour frame copied 1:1 into the atlas (one patch per
  // footprint_patch_tile_px tile, holding its triangles' pixels; no resampling, no per-triangle gutter); the others
  // get cells. 0 = off (every triangle gets a cell). 0.25 keeps the 0.5 px contract with a margin. On a TUM frame
  // meshed like the realtime preset this cuts the JPEG 3-4x against cells alone (bench/atlas_bench --footprint).
  double footprint_patch_deviation_px = 0.25;
  int footprint_patch_tile_px = 64;
  // Fill texels that no triangle samples smoothly (unsampled_fill.h). Unset: on for kFootprint, off for kAtlas and
  // kFrame (their goldens predate it). For kFrame, the texels are the frame's pixels that no triangle covers.
  std::optional<bool> fill_unsampled;
  // JPEG-encode the texture (Mesh::texture_encoded). false: the pixels only, for a caller that picks the quality
  // itself (a byte budget), which then encodes it once.
  bool encode = true;
};

struct AtlasResult {
  Mesh mesh;  // textured: positions, uvs, indices, texture, texture_encoded, texture_mime
  TextureMode mode = TextureMode::kAtlas;
  int width = 0, height = 0;                // texture size (texels)
  size_t texels = 0;                        // width * height
  size_t cells = 0;                         // atlas cells used (0 in frame mode)
  double packing_efficiency = 0.0;          // kFootprint: triangles' own texels / atlas texels (footprint_layout.h)
  size_t unsampled_texels = 0;              // texels no triangle samples (counted when they are filled)
  size_t patches = 0, patch_triangles = 0;  // kFootprint: frame patches and the triangles textured from them
  size_t triangles = 0;                     // triangles textured
  size_t dropped_triangles = 0;
  double median_source_px = 0.0;     // median projected area of a triangle in the colour image (pixels)
  double texels_per_triangle = 0.0;  // texels of a triangle's own area in its cell (frame mode: = source px)
  double ms = 0.0;                   // building the texture and the mesh, including the fill
  double fill_ms = 0.0;              // of which: filling unsampled texels
  double encode_ms = 0.0;            // JPEG encoding
};

Result<AtlasResult> build_atlas(const Mesh& mesh, const cv::Mat& color_rgb, const Intrinsics& pinhole,
                                const AtlasOptions& options = {});

}  // namespace rgbdcast
