#pragma once
// The representations a robot could send for one RGB-D frame, each as an encoder (frame -> bytes on the wire) and a
// decoder (bytes -> the Scene the receiver renders). Every decoder works from the bytes alone plus the camera
// intrinsics, which every receiver is assumed to know already (a few dozen bytes; the GLB carries them anyway).
//  - raw cloud: every valid pixel as float xyz + RGB, 15 bytes a point, no header beyond the count.
//  - JPEG + 16-bit PNG: colour JPEG (OpenCV), depth in the source's depth units as a 16-bit PNG (OpenCV); the
//    receiver back-projects every pixel with depth into a cloud, or (grid mesh) joins neighbouring pixels into
//    triangles where the depth is continuous.
//  - Draco point cloud: valid points, float positions quantized to N bits, colour as uint8, default speed.
//  - rgbdcast GLB: reduce_and_texture (pipeline/frame_scene.h) -> encode_glb (default GlbWriteOptions);
//    decode_glb on the receiving side.
#include <cstdint>
#include <vector>

#include "atlas/atlas.h"
#include "input/frame.h"
#include "reduction/pipeline.h"
#include "scene/result.h"
#include "scene/scene.h"

namespace rgbdcast::bench {

using Bytes = std::vector<std::uint8_t>;

// Raw cloud.
Bytes encode_raw_cloud(const RgbdFrame& frame);
Result<Scene> decode_raw_cloud(const Bytes& bytes, const Intrinsics& k);

// JPEG colour (quality 1..100) + 16-bit PNG depth; depth_step > 1 sends every depth_step-th depth pixel in each
// direction (lossy depth at half or quarter resolution), which the decoders bring back by nearest neighbour.
Result<Bytes> encode_jpeg_png(const RgbdFrame& frame, int jpeg_quality, int depth_step = 1);
Result<Scene> decode_jpeg_png_cloud(const Bytes& bytes, const Intrinsics& k);
// The same bytes meshed on the receiver: a triangle between neighbouring pixels when all three have depth and
// the largest depth is within max_jump of the smallest (relative, e.g. 0.05 = 5 %).
Result<Scene> decode_jpeg_png_grid_mesh(const Bytes& bytes, const Intrinsics& k, double max_jump = 0.05);

// Draco point cloud.
Result<Bytes> encode_draco(const RgbdFrame& frame, int position_bits);
Result<Scene> decode_draco(const Bytes& bytes, const Intrinsics& k);

// rgbdcast GLB. Timings of the three sender stages are returned through stage_ms (reduce, texture, glb).
struct RgbdcastStageMs {
  double reduce_ms = 0, texture_ms = 0, glb_ms = 0;
};
// params: default ReductionParams unless given (the bench adds the organized outlier filter as an extra row).
// Through pipeline/frame_scene.h, as `rgbdcast reduce`; budget_kb needs the realtime preset (0 = none).
Result<Bytes> encode_rgbdcast(const RgbdFrame& frame, TextureMode mode, RgbdcastStageMs* stage_ms = nullptr,
                              const ReductionParams& params = {}, double budget_kb = 0);
Result<Scene> decode_rgbdcast(const Bytes& bytes);

}  // namespace rgbdcast::bench
