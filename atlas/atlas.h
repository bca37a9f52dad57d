#pragma once
// Texturing a reduced mesh from its colour frame (paper, section 3.3), in one of two modes:
//  - kAtlas: every triangle gets its own undistorted texture in a square cell of an atlas (see atlas_layout.h and
//    triangle_homography.h); the output mesh gives each triangle its own three vertices (positions duplicated) with
//    UVs at its cell's corners.
//  - kFrame: the baseline: the whole colour frame is the texture and each vertex's UV is its projected pixel
//    (projective texturing, affine across each triangle, so large oblique triangles are distorted). Shared vertices
//    are kept (reordered for compression when reorder_triangles; vertices no triangle uses are dropped).
// Input: mesh positions in the camera frame of color_rgb (CV_8UC3, RGB order) which is already undistorted, so
// `pinhole` must be the pinhole intrinsics (distortion ignored) of that image. Triangles with a vertex at z <= 0 or
// no area are dropped (counted). The texture is returned as pixels (Mesh::texture, RGB8) and JPEG-encoded
// (Mesh::texture_encoded, texture_mime "image/jpeg").
#include <opencv2/core.hpp>
#include <string>

#include "scene/intrinsics.h"
#include "scene/mesh.h"
#include "scene/result.h"

namespace rgbdcast {

// kAuto picks per frame: the atlas when the mesh's median triangle covers more source pixels than a cell gives it
// (undistortion then matters), else the frame texture (tiny triangles: projective texturing is exact to a pixel and
// the frame costs far fewer bytes; see BENCHMARKS.md). AtlasResult::mode says which was used.
enum class TextureMode { kAtlas, kFrame, kAuto };
const char* to_string(TextureMode mode);
// "atlas", "frame" or "auto"; anything else is kInvalidArgument.
Result<TextureMode> parse_texture_mode(const std::string& name);

struct AtlasOptions {
  TextureMode mode = TextureMode::kAtlas;
  int cell_size_px = 8;     // side of a square cell (texels); 8 aligns cells with JPEG blocks
  int gutter_px = 1;        // texels kept free around each triangle (filled from the triangle's own plane)
  bool two_per_cell = true; // upper + lower triangle per cell (halves the atlas)
  int jpeg_quality = 85;    // 1..100
  bool reorder_triangles = true;  // meshoptimizer vertex-cache order: neighbouring triangles in neighbouring cells
  int max_atlas_side_px = 8192;
};

struct AtlasResult {
  Mesh mesh;               // textured: positions, uvs, indices, texture, texture_encoded, texture_mime
  TextureMode mode = TextureMode::kAtlas;
  int width = 0, height = 0;  // texture size (texels)
  size_t texels = 0;          // width * height
  size_t cells = 0;           // atlas cells used (0 in frame mode)
  size_t triangles = 0;       // triangles textured
  size_t dropped_triangles = 0;
  double median_source_px = 0.0;  // median projected area of a triangle in the colour image (pixels)
  double texels_per_triangle = 0.0;  // texels of a triangle's own area in its cell (frame mode: = source px)
  double ms = 0.0;            // building the texture and the mesh
  double encode_ms = 0.0;     // JPEG encoding
};

Result<AtlasResult> build_atlas(const Mesh& mesh, const cv::Mat& color_rgb, const Intrinsics& pinhole,
                                const AtlasOptions& options = {});

}  // namespace rgbdcast
