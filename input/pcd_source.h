#pragma once
// Organized PCD files (x y z rgb/rgba, NaN = invalid), as PCL's OpenNI grabber records them. Kept in its own
// translation unit: PCL's I/O templates are slow to compile.
#include <memory>
#include <string>

#include "input/frame_source.h"

namespace rgbdcast {

// One frame: colour from the rgb field, depth and organized xyz from the points. The intrinsics give the image
// size to expect; the points themselves are used as they are (no back-projection).
Result<std::unique_ptr<FrameSource>> open_pcd_source(const std::string& path, const Intrinsics& intrinsics);

}  // namespace rgbdcast
