#pragma once
// One function, frame -> textured scene node: the reduction (any preset, reduction/pipeline.h), the texture
// (atlas/atlas.h) and, for the realtime preset, a byte budget met through the GLB encoder (gltf/gltf_io.h). It is
// the only place that chains them: `rgbdcast reduce` (one frame and --sequence), the service's server-side
// reduction, the benches and the tests all call it. It sits above reduction/, atlas/ and gltf/, and below app/ and
// service/.
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "atlas/atlas.h"
#include "gltf/gltf_io.h"
#include "input/frame.h"
#include "reduction/coverage_filter.h"
#include "reduction/pipeline.h"
#include "scene/scene.h"

namespace rgbdcast {

struct FrameReductionOptions {
  ReductionParams params;  // the preset and every stage's parameters
  // kAuto: with the paper preset, the atlas when the mesh's triangles are large (atlas.h); with the realtime preset,
  // the frame texture, its triangles split until affine texturing is within DepthMeshParams::texture_deviation_px
  // of the projective mapping. An explicit mode is used as given.
  TextureMode texture = TextureMode::kAuto;
  AtlasOptions atlas;  // cell size, JPEG quality (a budget chooses the quality itself)
  GlbWriteOptions glb;
  // Realtime preset: choose the mesh tolerance and the texture's quality and scale so that the GLB lands within
  // +-10 % of budget_kb * 1000 bytes, or under it when the scene needs less. 0: no budget.
  double budget_kb = 0;
  // With a budget: at most a quarter of the frame's own JPEG q90 + PNG16 payload too (the realtime preset's default,
  // default_budget_kb in pipeline/frame_defaults.h, which reduce, sequence mode and the service ask for this way);
  // the budget used is the report's budget_bytes.
  bool budget_within_payload_share = false;
  // The budget's split: the mesh keeps its tolerance while its bytes are at most this share of the budget; beyond it
  // the tolerance rises until they are. The texture gets the rest (bench/realtime_bench measures the split).
  double budget_geometry_share = 0.45;
  // Past the largest tolerance, the texture resolution the budget keeps before it straightens the mesh's outline:
  // the collapses' limit is raised only while JPEG quality 30 at this scale would not fit beside the mesh.
  // 0.25..1 (the texture's own limit is a quarter). At 40 kB, 1 against 0.5 (TUM fr1/xyz 0, fr3 0, augmented ICL 0,
  // which then straighten by 2 px instead of halving the texture): PSNR over the pixels drawn +1.9 / +3.5 / +3.0 dB,
  // over all valid pixels +0.9 / +1.8 / +0.6 dB, coverage within 0.0004. Between a half and 1, the texture is tried
  // at this scale before half when the least quality does not fit at full size.
  double budget_outline_texture_scale = 1.0;
  // The best JPEG quality a budget tries (20..100). 92 by default; a large budget whose scene saturates at 92 (a
  // stream's refinements, rgbdcast stream --fine-max-quality) can turn more bytes into a better texture above it.
  int budget_max_jpeg_quality = 92;

  // The budget as reduce, sequence mode and the service set it from what was asked: asked_kb >= 0 is that budget;
  // otherwise the preset's default: for realtime min(kDefaultBudgetKb, a quarter of the frame's JPEG90+PNG16
  // payload), estimated by reduce_and_texture (pipeline/frame_defaults.h), for paper none.
  void use_budget(Preset preset, double asked_kb);
  Status validate() const;
};

// What a budget chose, and what it gave (reported in the GLB's extras and the reduce report).
struct BudgetChoice {
  double budget_bytes = 0;      // 0: no budget
  double tolerance_factor = 0;  // mesh tolerance (sigma units)
  double simplify_px = 0;       // the collapses' limit (DepthMeshParams::simplify_px, raised past the tolerance's)
  int jpeg_quality = 0;
  double texture_scale = 1.0;                                   // texture resolution relative to the colour frame
  size_t geometry_bytes = 0, texture_bytes = 0, glb_bytes = 0;  // of the node alone (no extras)
  int encodes = 0;                                              // GLB encodes and JPEG encodes tried
  int meshes = 0;  // meshes extracted, textured and measured (1 or 2 when the prior was close)
  // Which case applied: "fits" (the scene needs less), "texture-fitted" (the mesh at its tolerance, the texture
  // fitted), "geometry-capped" (the tolerance raised too), "outline-capped" (past the largest tolerance, the
  // collapses' limit raised too), "over-budget" (the limits of tolerance, collapses and texture scale reached: the
  // GLB is larger than the budget).
  std::string rule;
};

struct TexturedFrame {
  SceneNode node;
  CaptureCamera camera;
  std::vector<StageReport> stages;  // the reduction's stages, "covered" (with earlier views), "atlas" (the
                                    // texture, whichever mode), "budget" (with a budget)
  AtlasResult atlas_stats;          // the texture's figures (its mesh moved into node)
  BudgetChoice budget;              // budget_bytes == 0 when none was asked
  Preset preset = Preset::kPaper;
  // The budget's Draco results (its geometry measurement): writing the GLB with write_options() reuses them
  // instead of compressing the same mesh again (about 4.5 ms CPU a realtime frame). Null without a Draco budget.
  std::shared_ptr<DracoCache> geometry_cache;
};

// `base` with the frame's geometry cache, for the encode_glb that writes this frame.
GlbWriteOptions write_options(const TexturedFrame& frame, GlbWriteOptions base);

// Reduces and textures one frame; the node and camera are placed at camera_to_world. With `earlier` views, the
// triangles they already cover are dropped before texturing (stage "covered"). Errors: the options' or the
// reduction's (kInvalidArgument, kInvalidInput, kEmpty).
Result<TexturedFrame> reduce_and_texture(const RgbdFrame& frame, const FrameReductionOptions& options,
                                         const Eigen::Matrix4d& camera_to_world = Eigen::Matrix4d::Identity(),
                                         const std::vector<CoverageView>& earlier = {});

// The single-frame scene of a reduced frame: its node, its capture camera, and `extras_json` (a JSON object text).
// pipeline/keyframe_glb.h writes it as a keyframe's GLB, with its extras.
Scene frame_scene(TexturedFrame frame, std::string extras_json);

}  // namespace rgbdcast
