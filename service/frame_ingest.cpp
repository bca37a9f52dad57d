// The server-side reduction of an uploaded RGB-D frame (the multipart route of POST /v1/scenes): decode and validate
// the images, read the intrinsics, reduce and texture (pipeline/frame_scene.h, as `rgbdcast reduce`), encode the GLB. The
// result is what `rgbdcast reduce` writes for the same frame, and is then checked like any uploaded GLB.
#include <cmath>

#include "gltf/gltf_io.h"
#include "input/frame_source.h"
#include "input/intrinsics_io.h"
#include "pipeline/frame_defaults.h"
#include "pipeline/frame_scene.h"
#include "service/image_header.h"
#include "service/scene_ingest.h"

namespace rgbdcast::service {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

nlohmann::json stage_json(const StageReport& s) { return {{"name", s.name}, {s.unit, s.count}, {"ms", s.ms}}; }

Status check_image_size(const std::vector<unsigned char>& bytes, const char* part, int max_width, int max_height) {
  auto size = peek_image_size(bytes.data(), bytes.size());
  if (!size) return make_error(ErrorCode::kInvalidInput, std::string(part) + ": " + size.error().message);
  if (size->width > max_width || size->height > max_height)
    return make_error(ErrorCode::kInvalidInput, std::string(part) + ": " + std::to_string(size->width) + "x" +
                                                    std::to_string(size->height) + " is over the frame limit of " +
                                                    std::to_string(max_width) + "x" + std::to_string(max_height) +
                                                    " (--max-frame)");
  return ok_status();
}

}  // namespace

Result<IngestedScene> ingest_frame(const FrameUpload& upload) {
  std::vector<StageReport> stages;
  auto t = Clock::now();
  for (const auto& [bytes, part] : {std::pair{&upload.color, "color"}, std::pair{&upload.depth, "depth"}}) {
    auto st = check_image_size(*bytes, part, upload.max_width, upload.max_height);
    if (!st) return st.error();
  }
  auto intrinsics = parse_intrinsics_json(upload.intrinsics_json, "intrinsics");  // from memory, no paths
  if (!intrinsics) return intrinsics.error();
  {
    const Intrinsics& k = *intrinsics;
    if (!(std::isfinite(k.fx) && std::isfinite(k.fy) && k.fx > 0 && k.fy > 0))
      return make_error(ErrorCode::kInvalidInput, "intrinsics: focal lengths fx and fy must be positive numbers");
  }
  auto color = decode_color(upload.color, "color");
  if (!color) return make_error(ErrorCode::kInvalidInput, color.error().message);
  auto depth = decode_depth16(upload.depth, "depth");
  if (!depth) return make_error(ErrorCode::kInvalidInput, depth.error().message);
  auto frame = make_frame(*color, *depth, *intrinsics);
  if (!frame) return make_error(ErrorCode::kInvalidInput, frame.error().message);
  stages.push_back({"decode", "pixels", static_cast<size_t>(frame->color_rgb.total()), ms_since(t)});

  // The same frame -> scene function and options as `rgbdcast reduce` with its defaults.
  FrameReductionOptions options;
  options.params = reduction_preset(upload.preset);
  options.params.threads = upload.threads;
  options.glb.geometry_codec = default_geometry_codec(upload.preset);
  options.budget_kb = 0.0;
  if (upload.preset == Preset::kRealtime) {
    if (upload.budget_kb >= 0) {
      options.budget_kb = upload.budget_kb;
    } else {
      auto kb = default_budget_kb(*frame);
      if (!kb) return kb.error();
      options.budget_kb = *kb;
    }
  }
  if (auto st = options.validate(); !st) return st.error();  // a budget out of range: kInvalidArgument (400)
  auto textured = reduce_and_texture(*frame, options);
  if (!textured) return textured.error();
  for (const auto& s : textured->stages) stages.push_back(s);
  textured->camera.source = "upload";
  textured->camera.frame_index = 0;
  textured->node.name = "frame_0";
  const Intrinsics k = textured->camera.intrinsics;
  const nlohmann::json choices = nlohmann::json::parse(choices_json(*textured));
  nlohmann::json stage_list = nlohmann::json::array();
  for (const auto& s : stages) stage_list.push_back(stage_json(s));
  Scene scene = frame_scene(std::move(*textured),
                            nlohmann::json{{"rgbdcast",
                                            {{"source", "upload"},
                                             {"intrinsics",
                                              {{"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx}, {"cy", k.cy},
                                               {"width", k.width}, {"height", k.height}}},
                                             {"reduction", choices},
                                             {"stages", stage_list}}}}
                                .dump());
  t = Clock::now();
  auto glb = encode_glb(scene, options.glb);  // the codec the budget measured with
  if (!glb) return glb.error();
  const double export_ms = ms_since(t);

  // The stored GLB goes through the same check as an uploaded one.
  auto checked = ingest_glb(std::move(*glb));
  if (!checked) return make_error(ErrorCode::kInternal, "the server's own GLB does not decode: " +
                                                            checked.error().message);
  stages.push_back({"export", "bytes", checked->glb.size(), export_ms});
  checked->stats["source"] = "frame";
  checked->stats["stages"] = nlohmann::json::array();
  for (const auto& s : stages) checked->stats["stages"].push_back(stage_json(s));
  return checked;
}

}  // namespace rgbdcast::service
