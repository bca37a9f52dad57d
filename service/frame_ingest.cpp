// The server-side reduction of an uploaded RGB-D frame (the multipart route of POST /v1/scenes): decode and validate
// the images, read the intrinsics, reduce (reduction/pipeline.h), texture (atlas/atlas.h), encode the GLB. The
// result is what `rgbdcast reduce` writes for the same frame, and is then checked like any uploaded GLB.
#include <cmath>
#include <filesystem>

#include "atlas/atlas.h"
#include "gltf/gltf_io.h"
#include "input/frame_source.h"
#include "input/intrinsics_io.h"
#include "reduction/pipeline.h"
#include "service/image_header.h"
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
  if (!k) {
    // The reader names the file it read: the client only needs to know it was its intrinsics part.
    std::string why = k.error().message;
    for (size_t at = why.find(path); at != std::string::npos; at = why.find(path)) why.replace(at, path.size(), "part");
    return make_error(k.error().code == ErrorCode::kIo ? ErrorCode::kIo : ErrorCode::kInvalidInput,
                      "intrinsics: " + why);
  }
  return k;
}

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
  auto intrinsics = parse_uploaded_intrinsics(upload.intrinsics_json, upload.scratch_dir);
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

  auto reduced = reduce_frame(*frame, ReductionParams{});
  if (!reduced) return reduced.error();
  for (const auto& s : reduced->stages) stages.push_back(s);

  AtlasOptions texture;
  texture.mode = TextureMode::kAuto;  // as `rgbdcast reduce`: the atlas only where triangles are large enough to need it
  auto atlas = build_atlas(reduced->mesh, frame->color_rgb, frame->intrinsics.pinhole(), texture);
  if (!atlas) return atlas.error();
  stages.push_back({"atlas", "texels", atlas->texels, atlas->ms + atlas->encode_ms});

  Scene scene;
  CaptureCamera cam;
  cam.intrinsics = frame->intrinsics.pinhole();
  cam.source = "upload";
  cam.frame_index = 0;
  scene.cameras.push_back(cam);
  SceneNode node;
  node.name = "frame_0";
  node.mesh = std::move(atlas->mesh);
  scene.nodes.push_back(std::move(node));
  nlohmann::json stage_list = nlohmann::json::array();
  for (const auto& s : stages) stage_list.push_back(stage_json(s));
  const Intrinsics& k = cam.intrinsics;
  scene.extras_json = nlohmann::json{{"rgbdcast",
                                      {{"source", "upload"},
                                       {"intrinsics",
                                        {{"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx}, {"cy", k.cy},
                                         {"width", k.width}, {"height", k.height}}},
                                       {"stages", stage_list}}}}
                          .dump();
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
