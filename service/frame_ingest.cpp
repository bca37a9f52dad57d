// The server-side reduction of an uploaded RGB-D frame (the multipart route of POST /v1/scenes): decode and validate
// the images, read the intrinsics, reduce and texture (pipeline/frame_scene.h, as `rgbdcast reduce`), encode the GLB.
// The result is what `rgbdcast reduce` writes for the same frame, and is then checked like any uploaded GLB.
#include "base/stopwatch.h"
#include "gltf/gltf_io.h"
#include "pipeline/frame_defaults.h"
#include "pipeline/frame_scene.h"
#include "pipeline/keyframe_glb.h"
#include "service/scene_ingest.h"
#include "service/upload_body.h"

namespace rgbdcast::service {
namespace {

using Clock = std::chrono::steady_clock;

nlohmann::json stage_json(const StageReport& s) { return {{"name", s.name}, {s.unit, s.count}, {"ms", s.ms}}; }

}  // namespace

Result<IngestedScene> ingest_frame(const FrameUpload& upload) {
  std::vector<StageReport> stages;
  auto t = Clock::now();
  auto frame =
      decode_frame_parts(upload.color, upload.depth, upload.intrinsics_json, upload.max_width, upload.max_height);
  if (!frame) return frame.error();
  stages.push_back({"decode", "pixels", static_cast<size_t>(frame->color_rgb.total()), ms_since(t)});

  // The same frame -> scene function and options as `rgbdcast reduce` with its defaults.
  FrameReductionOptions options;
  options.params = reduction_preset(upload.preset);
  options.params.threads = upload.threads;
  options.glb.geometry_codec = default_geometry_codec(upload.preset);
  // A budget only for realtime (the paper preset has none, as before); without one asked, the frame's default.
  options.use_budget(upload.preset, upload.preset == Preset::kRealtime ? upload.budget_kb : 0.0);
  if (auto st = options.validate(); !st) return st.error();  // a budget out of range: kInvalidArgument (400)
  auto textured = reduce_and_texture(*frame, options);
  if (!textured) return textured.error();
  for (const auto& s : textured->stages) stages.push_back(s);
  textured->camera.source = "upload";
  textured->camera.frame_index = 0;
  textured->node.name = "frame_0";
  const Intrinsics k = textured->camera.intrinsics;
  nlohmann::json stage_list = nlohmann::json::array();
  for (const auto& s : stages) stage_list.push_back(stage_json(s));
  const nlohmann::json capture = {
      {"source", "upload"},
      {"intrinsics",
       {{"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx}, {"cy", k.cy}, {"width", k.width}, {"height", k.height}}},
      {"stages", stage_list}};
  t = Clock::now();
  auto glb = encode_keyframe_glb(std::move(*textured), capture, options.glb);
  if (!glb) return glb.error();
  const double export_ms = ms_since(t);

  // The stored GLB goes through the same check as an uploaded one.
  auto checked = ingest_glb(std::move(*glb));
  if (!checked)
    return make_error(ErrorCode::kInternal, "the server's own GLB does not decode: " + checked.error().message);
  stages.push_back({"export", "bytes", checked->glb.size(), export_ms});
  checked->stats["source"] = "frame";
  checked->stats["stages"] = nlohmann::json::array();
  for (const auto& s : stages) checked->stats["stages"].push_back(stage_json(s));
  return checked;
}

}  // namespace rgbdcast::service
