#pragma once
// The realtime preset's byte budget: the mesh's tolerance, its outline's collapses and the texture's JPEG quality and
// resolution chosen so that the frame's GLB fits a number of bytes. A state machine over one frame (BudgetSearch in
// budget_search.cpp): the mesh is extracted at a tolerance chosen from the hierarchy's triangle counts and a bytes-
// per-triangle figure (the codec's prior, then the one measured), its geometry measured in a GLB, then the texture's
// quality interpolated on log bytes against libjpeg's log quantizer scale. reduce_and_texture (frame_scene.h) is
// its one caller; the quality search's steps are here for their tests.
#include <cstdint>
#include <functional>
#include <vector>

#include "pipeline/frame_scene.h"

namespace rgbdcast {

// Limits of what a budget may give up (FrameReductionOptions::validate checks the options against them): the least
// JPEG quality a search tries, and the smallest texture scale.
inline constexpr int kBudgetMinJpegQuality = 20;
inline constexpr double kBudgetMinTextureScale = 0.25;

// The quality whose JPEG would have `target` bytes, between two qualities tried (q_lo with lo_bytes fits, q_hi with
// hi_bytes does not): log bytes interpolated against log quantizer scale, floored.
int guess_quality(int q_lo, double lo_bytes, int q_hi, double hi_bytes, double target);

// A JPEG encode of the texture tried by the budget: quality, resolution scale, bytes.
struct TriedJpeg {
  int quality;
  double scale;
  std::vector<std::uint8_t> bytes;
};

// The bytes of the encode tried at (q, scale), or -1.
double tried_bytes(const std::vector<TriedJpeg>& tried, int q, double scale);
// [*q_lo, *q_hi] (q_lo fits `target` bytes, q_hi does not) narrowed to the closest qualities tried at `scale`.
void narrow_to_tried(const std::vector<TriedJpeg>& tried, double scale, double target, int* q_lo, int* q_hi);
// The next qualities to try for `target` bytes strictly between q_lo and q_hi (both tried at `scale`): two either
// side of guess_quality's, clamped inside and without repeats; none when nothing lies between them.
std::vector<int> next_qualities(const std::vector<TriedJpeg>& tried, double scale, int q_lo, int q_hi, double target);

// The mesh at (tolerance, simplify_px) (simplify_px < 0: the parameters'), the triangles earlier views cover dropped
// and textured with the search's atlas options; its stages into *stages.
using TextureAtTolerance =
    std::function<Result<AtlasResult>(double tolerance, double simplify_px, std::vector<StageReport>* stages)>;

// What a search works on: the frame, its options and placement, the prepared hierarchy (realtime preset), the atlas
// options the texture is built with, and the budget in kB (options.budget_kb, capped by the payload's share).
struct BudgetInputs {
  const RgbdFrame& frame;
  const FrameReductionOptions& options;
  const Eigen::Matrix4d& camera_to_world;
  const std::vector<CoverageView>& earlier;
  const RealtimeReduction& prepared;
  const AtlasOptions& atlas;
  double budget_kb = 0;
  TextureAtTolerance texture_at;
};

// Meets in.budget_kb (> 0): out->budget gets the choice, out->node.mesh the textured mesh with its JPEG,
// out->atlas_stats its figures, out->stages the chosen mesh's stages and "budget", out->geometry_cache the Draco
// results for the final write. out->camera must be set (the measurement's GLB holds it). Errors: the reduction's,
// the atlas's and the encoders'.
Status meet_budget(const BudgetInputs& in, TexturedFrame* out);

}  // namespace rgbdcast
