#pragma once
// Internal to atlas/: input checks shared by both texture modes, and the projective baseline (TextureMode::kFrame).
#include "atlas/atlas.h"

namespace rgbdcast::atlas_detail {

// kInvalidArgument/kEmpty for an unusable mesh, image or intrinsics.
Status check_inputs(const Mesh& mesh, const cv::Mat& color_rgb, const Intrinsics& pinhole);
// Bilinear sample of an RGB8 Mat at pixel coordinates (pixel centres at integers), clamped to the image.
void sample_bilinear(const cv::Mat& rgb, double u, double v, std::uint8_t out[3]);
// The baseline: whole frame as texture, projected pixels as UVs.
Result<AtlasResult> build_frame_texture(const Mesh& mesh, const cv::Mat& color_rgb, const Intrinsics& pinhole,
                                        const AtlasOptions& options);
double median_projected_area_px(const Mesh& mesh, const Eigen::Matrix3d& K);
// Room in `out` for `triangles` triangles of three vertices each (the atlas modes' mesh).
void reserve_cell_triangles(size_t triangles, Mesh* out);
// The atlas modes' result: `texture` becomes the mesh's texture, and its size, cells and triangles are recorded.
void set_atlas_texture(Image texture, size_t cells, size_t triangles, AtlasResult* r);
// Appends triangle `tri` of `mesh` to the atlas mesh `out` with three vertices of its own, whose UVs are `corners`
// (atlas texels) times inv_size (1 / atlas width, 1 / atlas height). Both atlas modes build their mesh this way.
void append_cell_triangle(const Mesh& mesh, const std::array<std::uint32_t, 3>& tri,
                          const std::array<Eigen::Vector2d, 3>& corners, const Eigen::Vector2d& inv_size, Mesh* out);

}  // namespace rgbdcast::atlas_detail
