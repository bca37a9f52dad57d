#pragma once
// How faithfully a textured mesh reproduces its colour frame, measured on the surface rather than on a rendering:
// at points spread over every triangle (a barycentric grid), the texture lookup a renderer makes (UVs interpolated
// perspective-correctly, i.e. linearly in the 3D point's barycentric coordinates; bilinear filtering) is compared
// with the colour image sampled where the 3D point projects. Both texture modes are measured the same way.
#include <opencv2/core.hpp>

#include "scene/image.h"
#include "scene/intrinsics.h"
#include "scene/mesh.h"

namespace rgbdcast {

struct TextureFidelity {
  double psnr_db = 0.0;
  double mean_abs = 0.0;  // mean absolute difference per channel (0..255)
  size_t samples = 0;
};

// `texture` is what the viewer would see (e.g. the decoded JPEG); mesh.uvs index into it.
// samples_per_edge: the barycentric grid's resolution (n -> (n+1)(n+2)/2 points per triangle).
TextureFidelity measure_texture_fidelity(const Mesh& mesh, const Image& texture, const cv::Mat& color_rgb,
                                         const Intrinsics& pinhole, int samples_per_edge = 6);
// Decodes Mesh::texture_encoded (JPEG/PNG) to RGB8; empty Image if it does not decode.
Image decode_texture(const Mesh& mesh);

}  // namespace rgbdcast
