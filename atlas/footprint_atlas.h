#pragma once
// Internal to atlas/: TextureMode::kFootprint (see atlas.h, footprint_layout.h, unsampled_fill.h). Patch triangles:
// all three projections inside the image, a bounding box within one tile, and affine_deviation (the frame mapping's
// distance from the projective one at the edge midpoints and the centroid) under the option; a patch is the pixel
// rectangle its tile's triangles read bilinearly, copied as is.
#include "atlas/atlas.h"

namespace rgbdcast::atlas_detail {

// Inputs already checked (check_inputs, JPEG quality). kInvalidArgument when texels_per_px is not in (0, 16], the
// gutter is not 1..16, or the cells exceed max_atlas_side_px; kEmpty when no triangle is in front of the camera with
// an area.
Result<AtlasResult> build_footprint_atlas(const Mesh& mesh, const cv::Mat& color_rgb, const Intrinsics& pinhole,
                                          const AtlasOptions& options);

}  // namespace rgbdcast::atlas_detail
