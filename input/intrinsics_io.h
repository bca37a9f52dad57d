#pragma once
// Intrinsics presets and files.
#include <optional>
#include <string>
#include <string_view>

#include "scene/intrinsics.h"
#include "scene/result.h"

namespace rgbdcast {

// "fr1", "fr2", "fr3" (TUM, with their published distortion) or "kinect" (525/525/319.5/239.5, no distortion).
std::optional<Intrinsics> intrinsics_preset(const std::string& name);
// Intrinsics JSON from memory (an upload), untrusted: either {fx, fy, cx, cy, width, height, distortion?:
// [k1,k2,p1,p2,k3], depth_scale?} or Open3D's camera JSON {width, height, intrinsic_matrix: [9 numbers,
// column-major]}. At most kMaxIntrinsicsJsonBytes and 16 levels deep. fx, fy > 0 and finite; width and height
// 1..16384; depth_scale > 0. Errors are kInvalidInput, one line, prefixed with `what` (never a path unless the
// caller passes one). Intrinsics::name is set to `what`.
inline constexpr size_t kMaxIntrinsicsJsonBytes = size_t(1) << 20;
Result<Intrinsics> parse_intrinsics_json(std::string_view text, const std::string& what = "intrinsics");
// The same from a file; errors name the path (kNotFound when it cannot be opened).
Result<Intrinsics> load_intrinsics_json(const std::string& path);
// A 3x3 camera matrix in plain text, as SUN3D and 3DMatch's camera-intrinsics.txt: nine numbers separated by white
// space, row by row "fx 0 cx / 0 fy cy / 0 0 1" (no skew; fx, fy > 0, all finite), at most kMaxIntrinsicsTextBytes.
// The text gives no image size: width and height are 0, and the frame source takes them from the first colour image.
// depth_scale is 1000 (millimetres, as those datasets store depth). Errors are kInvalidInput, one line, prefixed with
// `what`.
inline constexpr size_t kMaxIntrinsicsTextBytes = 4096;
Result<Intrinsics> parse_intrinsics_matrix_text(std::string_view text, const std::string& what = "intrinsics");
// A preset name, a JSON file path, or a .txt path (a 3x3 matrix, above).
Result<Intrinsics> resolve_intrinsics(const std::string& spec);

}  // namespace rgbdcast
