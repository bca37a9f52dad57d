#pragma once
// What the service accepts as a scene, turned into the GLB it stores and the stats it reports.
// - A GLB from a client (untrusted): decoded with decode_glb before anything is stored; a truncated or invalid file
//   or a scene with nothing to draw is kInvalidInput/kEmpty (HTTP 422).
// - A frame upload (colour PNG/JPEG, 16-bit depth PNG, intrinsics JSON; optionally a preset and a budget): decoded,
//   reduced and textured (reduce_and_texture, with `rgbdcast reduce`'s defaults: pipeline/frame_defaults.h) and
//   encoded (encode_glb, with the preset's geometry codec) on the server.
// Stats (JSON): points, vertices, triangles, nodes, bytes, capture_camera, stages (name, unit, count, ms).
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "pipeline/frame_defaults.h"
#include "reduction/pipeline.h"

#include "scene/result.h"
#include "scene/scene.h"

namespace rgbdcast::service {

struct IngestedScene {
  std::vector<std::uint8_t> glb;
  nlohmann::json stats;
};

Result<IngestedScene> ingest_glb(std::vector<std::uint8_t> glb);
// The decode and checks of ingest_glb (kInvalidInput, kEmpty), for callers that keep the Scene (a mission keyframe).
Result<Scene> decode_client_glb(const std::vector<std::uint8_t>& glb);

struct FrameUpload {
  std::vector<unsigned char> color;  // PNG or JPEG bytes
  std::vector<unsigned char> depth;  // 16-bit single-channel PNG bytes
  std::string intrinsics_json;       // as load_intrinsics_json reads
  std::string scratch_dir;           // a folder for a short-lived temporary file (the store's folder)
  Preset preset = kDefaultPreset;    // the reduction's preset (its defaults): realtime unless the upload asks
  // Realtime preset: the GLB's byte budget in kB (0 = none; < 0: the frame's default, default_budget_kb:
  // min(40 kB, a quarter of its JPEG90+PNG16 payload)). The paper preset takes none.
  double budget_kb = -1;
  int max_width = 1920, max_height = 1080;  // images larger than this are refused from their header, undecoded
  int threads = 0;                          // OpenMP threads of the reduction (ReductionParams::threads)
};
// Checks first, before anything is decoded or reduced: both images are PNG/JPEG no larger than max_width x
// max_height (kInvalidInput, HTTP 422), the intrinsics parse and have finite positive focal lengths. Error texts
// carry no server path. Seconds of CPU: call it from a worker (service/job_queue.h), not from an HTTP thread.
Result<IngestedScene> ingest_frame(const FrameUpload& upload);

// Stats of a decoded scene, and the stages of its capture (from the GLB's extras) when present.
nlohmann::json scene_stats(const Scene& scene, size_t glb_bytes);

}  // namespace rgbdcast::service
