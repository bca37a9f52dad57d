#pragma once
// What a user gets when they name no preset and no budget: the one home of these defaults for `rgbdcast reduce` (one
// frame and --sequence) and the service's server-side reduction (multipart frame uploads), so they cannot drift
// apart. ReductionParams{} stays the paper's values (reduction/pipeline.h); the product's default is realtime
// because the benchmark shows it wins over the paper preset on time, bytes, coverage and novel-view fidelity
// (BENCHMARKS.md, "Realtime preset").
#include <cstdint>
#include <vector>

#include "gltf/gltf_io.h"
#include "input/frame.h"
#include "reduction/pipeline.h"
#include "scene/result.h"

namespace rgbdcast {

// The default preset of reduce, sequence mode and the service.
constexpr Preset kDefaultPreset = Preset::kRealtime;

// The realtime preset's largest default byte budget (kB). The default budget of a frame is this, or a quarter of
// the frame's JPEG q90 + PNG16 payload when that is smaller (default_budget_kb).
constexpr double kDefaultBudgetKb = 40;
constexpr double kDefaultBudgetPayloadShare = 0.25;

// The preset's geometry codec when none is asked for: Draco for realtime (half meshopt's geometry bytes, so a frame
// fits 40 kB), meshopt for paper.
GeometryCodec default_geometry_codec(Preset preset);

// What a robotics engineer sends today for one frame: the colour as JPEG at `jpeg_quality` (OpenCV's encoder, BGR)
// and the depth in the sensor's integer units (depth_m * intrinsics.depth_scale) as a 16-bit PNG at OpenCV's
// default compression, at 1/depth_step of the resolution (nearest). kInternal when OpenCV cannot encode.
struct JpegPng16 {
  std::vector<std::uint8_t> jpeg, png;
  size_t bytes() const { return jpeg.size() + png.size(); }
};
Result<JpegPng16> encode_jpeg_png16(const RgbdFrame& frame, int jpeg_quality, int depth_step = 1);

// The realtime preset's default budget for this frame: min(kDefaultBudgetKb, a quarter of its JPEG90+PNG16
// payload), so the GLB is at most a quarter of what the frame costs as images also on frames whose images
// compress well (the PCL Kinect PCDs: 130.7 kB of JPEG90+PNG16, so 32.7 kB). Costs one JPEG and one PNG encode of
// the frame (measured in BENCHMARKS.md, "Default budget"). Never below 4 kB (FrameReductionOptions'
// floor). Errors: encode_jpeg_png16's. reduce_and_texture makes the same estimate when
// FrameReductionOptions::budget_within_payload_share is set (what reduce, sequence mode and the service do).
Result<double> default_budget_kb(const RgbdFrame& frame);
// A quarter of the frame's JPEG90+PNG16 payload, never below 4 kB (default_budget_kb without its 40 kB cap).
Result<double> payload_share_kb(const RgbdFrame& frame);

}  // namespace rgbdcast
