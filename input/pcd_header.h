#pragma once
// The PCD header check in front of PCL's reader (pcd_source.cpp), in a translation unit without PCL.
#include <cstddef>
#include <cstdint>
#include <string>

#include "scene/result.h"

namespace rgbdcast {

// The PCD header, checked by rgbdcast before PCL reads the file (PCL sizes its buffers from the header alone: an
// ASCII file of a few bytes can claim 64 M points). Contract: the header is at most 64 KiB of "KEY values" lines up
// to DATA, with the format's keys only; FIELDS/SIZE/TYPE/COUNT agree (at most 64 fields of 1, 2, 4 or 8 bytes, a
// point at most 4 KiB), and hold x, y, z (4-byte floats) and rgb or rgba (4 bytes), every field named once with
// COUNT 1 except "_" padding; VIEWPOINT is 7 numbers; WIDTH and HEIGHT are 2..8192 (an organized frame) and POINTS,
// when given, is WIDTH x HEIGHT; the bytes after DATA do not read as more header lines (PCL reads on); and they can
// hold the points: binary needs POINTS x point size, binary_compressed its 8-byte sizes, the compressed bytes they
// announce and an uncompressed size of exactly POINTS x point size, ASCII one line of numbers per point.
// Errors are kInvalidInput "PCD: ...", one line. Reads only data[0, size).
struct PcdHeader {
  int width = 0, height = 0;
  size_t point_bytes = 0;
  std::string data;  // ascii, binary, binary_compressed
};
Result<PcdHeader> check_pcd_header(const std::uint8_t* data, size_t size);

}  // namespace rgbdcast
