#pragma once
// Intrinsics presets and files.
#include <optional>
#include <string>

#include "scene/intrinsics.h"
#include "scene/result.h"

namespace rgbdcast {

// "fr1", "fr2", "fr3" (TUM, with their published distortion) or "kinect" (525/525/319.5/239.5, no distortion).
std::optional<Intrinsics> intrinsics_preset(const std::string& name);
// A JSON file: either {fx, fy, cx, cy, width, height, distortion?: [k1,k2,p1,p2,k3], depth_scale?}
// or Open3D's camera JSON {width, height, intrinsic_matrix: [9 numbers, column-major]}.
Result<Intrinsics> load_intrinsics_json(const std::string& path);
// A preset name or a JSON file path.
Result<Intrinsics> resolve_intrinsics(const std::string& spec);

}  // namespace rgbdcast
