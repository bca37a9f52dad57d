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

}  // namespace rgbdcast::atlas_detail
