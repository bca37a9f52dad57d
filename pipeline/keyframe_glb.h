#pragma once
// A reduced frame as the GLB `rgbdcast reduce`, the server's frame upload and the streamer write: the one place the
// keyframe's extras are assembled and the GLB is encoded with the budget's geometry results.
//
// Extras: the scene's {"rgbdcast": capture + {"reduction": reduction_choices(frame)}}, where `capture` holds what
// the caller knows of the capture (its source, frame index, timestamp, intrinsics, stage reports).
#include <cstdint>
#include <nlohmann/json.hpp>
#include <vector>

#include "pipeline/frame_scene.h"

namespace rgbdcast {

// The texture and budget choices, for extras and reports: {"preset", "texture", "budget"?} (budget only when one
// was asked: its bytes, tolerance, collapses, JPEG quality and scale, the bytes it measured, its encodes, meshes and
// rule).
nlohmann::json reduction_choices(const TexturedFrame& frame);

// The frame's single-node scene (frame_scene) with the extras above, encoded with write_options(frame, glb).
// capture: a JSON object (an "reduction" field in it is replaced); stats (optional) gets the encoder's figures.
// Errors: kInvalidArgument when capture is not an object; the encoder's.
Result<std::vector<std::uint8_t>> encode_keyframe_glb(TexturedFrame frame, nlohmann::json capture,
                                                      const GlbWriteOptions& glb, GlbStats* stats = nullptr);

}  // namespace rgbdcast
