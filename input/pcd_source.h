#pragma once
// Organized PCD files (x y z rgb/rgba, NaN = invalid), as PCL's OpenNI grabber records them. Kept in its own
// translation unit: PCL's I/O templates are slow to compile.
#include <cstdint>
#include <memory>
#include <string>

#include "input/frame_source.h"

namespace rgbdcast {

// The PCD header, checked by rgbdcast before PCL reads the file (PCL sizes its buffers from the header alone: an
// ASCII file of a few bytes can claim 64 M points). Contract: the header is at most 64 KiB of "KEY values" lines up
// to DATA, with the format's keys only; FIELDS/SIZE/TYPE/COUNT agree (at most 64 fields of 1, 2, 4 or 8 bytes, a
// point at most 4 KiB), and hold x, y, z (4-byte floats) and rgb or rgba (4 bytes), every field named once with
// COUNT 1 except "_" padding; WIDTH and HEIGHT are 2..8192 (an organized frame) and POINTS, when given, is WIDTH x HEIGHT; and the bytes
// after the header can hold the points: binary needs POINTS x point size, binary_compressed its 8-byte sizes, the
// compressed bytes they announce and an uncompressed size of exactly POINTS x point size, ASCII at least 2 bytes per
// value. Errors are kInvalidInput "PCD: ...", one line.
struct PcdHeader {
  int width = 0, height = 0;
  size_t point_bytes = 0;
  std::string data;  // ascii, binary, binary_compressed
};
Result<PcdHeader> check_pcd_header(const std::uint8_t* data, size_t size);

// One frame: colour from the rgb field, depth and organized xyz from the points. The intrinsics give the image
// size to expect; the points themselves are used as they are (no back-projection).
Result<std::unique_ptr<FrameSource>> open_pcd_source(const std::string& path, const Intrinsics& intrinsics);

}  // namespace rgbdcast
