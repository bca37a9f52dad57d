#pragma once
// Spending texture bytes only on what is drawn: texels that no triangle's lookup can reach are replaced by a smooth
// continuation of the texels around them, so that a JPEG encoder spends next to nothing on them (a flat or slowly
// varying 8x8 block costs a few bits; the camera image or a black gap next to a cell costs many).
//
// Both functions work in texel units of the texture: texel (i, j) covers [i, i+1] x [j, j+1] (UV (0, 0) is the
// top-left corner of the image), as glTF and this project's atlas use. They are not thread-safe on the same image.
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "scene/image.h"
#include "scene/mesh.h"
#include "scene/result.h"

namespace rgbdcast {

// Texels (width x height, row-major, 1 = sampled) that a bilinear lookup at any point of any of the mesh's triangles
// reads with a weight of 1e-3 or more, from the triangles' UVs (mesh.uvs, 0..1 over the texture): texel (i, j) is
// marked when the triangle meets the square of half-width 1 - 1e-3 around its centre (exact for bilinear filtering,
// also at the texture's clamped border). Works for any texture layout, e.g. the frame texture (TextureMode::kFrame)
// where it is the colour frame's pixels that some triangle covers. kInvalidArgument when uvs do not match positions, an
// index is out of range, a UV is not finite, or the size is not positive.
Result<std::vector<std::uint8_t>> texels_sampled_by_uvs(const Mesh& mesh, int width, int height);

// The same for one triangle given in texel units (a UV times the texture size); marks into mask (width x height).
void mark_sampled_texels(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c, int width,
                         int height, std::uint8_t* mask);

// Push-pull fill: every texel with sampled == 0 gets the value of a pyramid of averages of the sampled texels
// (each level halves the size, averaging only sampled texels), pulled back up with bilinear interpolation, coarse to
// fine. Where a whole 16x16 block (a JPEG MCU with 4:2:0 chroma) or 8x8 block (a luma block), aligned to the image's
// origin, has no sampled texel, it is flat at its pyramid value instead, so JPEG codes it as a DC difference alone.
// Sampled texels keep their exact bytes. With no sampled texel at all, the image becomes mid-grey.
// image: RGB8 (3 channels) or RGBA8 (4, alpha filled too); sampled: width * height entries.
// kInvalidArgument for a mask of the wrong size or an image that is neither. About 1-3 ms for a 640x480 RGB image on
// one core (bench/atlas_bench).
Status fill_unsampled_texels(Image* image, const std::vector<std::uint8_t>& sampled);

}  // namespace rgbdcast
