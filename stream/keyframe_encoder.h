#pragma once
// A keyframe's GLB for the stream: the one frame -> scene call (pipeline/frame_scene.h) at a byte budget, written as
// `rgbdcast reduce` writes it, with the mesh and capture camera in the keyframe's own camera frame (the world pose
// travels in the POST, stream/uplink.h).
#include <cstdint>
#include <vector>

#include "pipeline/frame_scene.h"

namespace rgbdcast::stream {

// Fidelity for large budgets. The realtime reduction's defaults saturate on a delta keyframe well under 100 kB
// (tolerance at its floor of 2 sigma, JPEG at its budget's best quality 92, collapses at 2 px), so the bytes a fast
// link has room for could buy nothing. A keyframe or refinement whose budget is above `above_kb` is reduced with
// these settings instead; the budget still raises the tolerance and lowers the quality as it needs. By default only
// the JPEG ceiling moves (92 -> 98; the measurements are in docs/streaming.md).
struct FineReduction {
  double above_kb = 40;       // --fine-above-kb: budgets above this use the settings below (0: never)
  double tolerance = 2.0;     // --fine-tolerance: the tolerance floor, sigma (never above the default reduction's)
  double simplify_px = 2.0;   // --fine-simplify-px: the collapses' limit (0: off; never above the default's)
  int max_jpeg_quality = 98;  // --fine-max-quality: the budget's best JPEG quality (never below the default's 92)
};

// `base` for a keyframe or refinement of budget_kb: above fine.above_kb (when that is > 0), its tolerance floor and
// collapses at most fine's, its best JPEG quality at least fine's; otherwise `base` as it is.
FrameReductionOptions reduction_for_budget(const FrameReductionOptions& base, const FineReduction& fine,
                                           double budget_kb);

struct EncodedKeyframe {
  std::vector<std::uint8_t> glb;
  size_t triangles = 0;
  bool fits = false;  // the budget's rule "fits": the finest mesh and best quality its settings allow, under budget
};

// Reduces `frame` at budget_kb (options' own budget_kb is replaced) against the earlier keyframes' coverage views.
// Errors: the reduction's (kEmpty when nothing is new) and the GLB encoder's.
Result<EncodedKeyframe> encode_keyframe(const RgbdFrame& frame, FrameReductionOptions options, double budget_kb,
                                        const Eigen::Matrix4d& camera_to_world,
                                        const std::vector<CoverageView>& earlier);

}  // namespace rgbdcast::stream
