// The server-side reduction of an uploaded RGB-D frame (the multipart route of POST /v1/scenes): decode and validate
// the images, read the intrinsics, reduce and texture (pipeline/frame_scene.h, as `rgbdcast reduce`), encode the GLB. The
// result is what `rgbdcast reduce` writes for the same frame, and is then checked like any uploaded GLB.
#include <filesystem>

#include "gltf/gltf_io.h"
#include "input/frame_source.h"
#include "input/intrinsics_io.h"
#include "pipeline/frame_scene.h"
#include "service/scene_ingest.h"
#include "service/scene_store.h"

namespace rgbdcast::service {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

nlohmann::json stage_json(const StageReport& s) { return {{"name", s.name}, {s.unit, s.count}, {"ms", s.ms}}; }

// load_intrinsics_json reads a file: the uploaded text goes to a short-lived temporary file in the store's folder
// (its name starts with the store's temporary prefix, so a crash leaves nothing that survives a restart).
Result<Intrinsics> parse_uploaded_intrinsics(const std::string& text, const std::string& scratch_dir) {
  if (text.empty()) return make_error(ErrorCode::kInvalidInput, "intrinsics: empty part");
  if (text.size() > (1u << 20)) return make_error(ErrorCode::kInvalidInput, "intrinsics: over 1 MiB of JSON");
  const std::string name = ".tmp-intrinsics-" + new_scene_id() + ".json";
  auto st = write_file_atomic(scratch_dir, name, text.data(), text.size());
  if (!st) return st.error();
  const std::string path = scratch_dir + "/" + name;
  auto k = load_intrinsics_json(path);
  std::error_code ec;
  std::filesystem::remove(path, ec);
  if (!k) return make_error(k.error().code == ErrorCode::kIo ? ErrorCode::kIo : ErrorCode::kInvalidInput,
                            "intrinsics: " + k.error().message);
  return k;
}

}  // namespace

Result<IngestedScene> ingest_frame(const FrameUpload& upload) {
  std::vector<StageReport> stages;
  auto t = Clock::now();
  auto intrinsics = parse_uploaded_intrinsics(upload.intrinsics_json, upload.scratch_dir);
  if (!intrinsics) return intrinsics.error();
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
  options.budget_kb = upload.preset == Preset::kRealtime ? upload.budget_kb : 0.0;
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
  auto glb = encode_glb(scene);
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
