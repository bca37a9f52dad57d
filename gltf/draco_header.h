#pragma once
// The counts at the start of a Draco mesh bitstream, read without Draco, so that a hostile file is refused before the
// decoder allocates for them: Draco 1.5.5 sizes its corner table from num_faces and the edgebreaker vertex counts,
// and its attribute buffers from the sequential num_points, without comparing them with the bytes present (the
// Draco API has no call that returns them). Layout (Draco bitstream 2.2, the version KHR_draco_mesh_compression
// names): "DRACO", major, minor, encoder type (1 = triangle mesh), method (0 sequential, 1 edgebreaker), u16 flags;
// then for sequential: varint num_faces, varint num_points; for edgebreaker: u8 traversal type, varint
// num_encoded_vertices, varint num_faces, u8 attribute data count, varint symbols, varint split symbols.
// Accepted: version 2.2 only, triangle meshes, no metadata (flag 0x8000): anything else is kInvalidInput.
// Contract: reads only data[0, size); pure, thread-safe, no allocation.
#include <cstddef>
#include <cstdint>

#include "scene/result.h"

namespace rgbdcast::glb {

struct DracoHeaderCounts {
  bool edgebreaker = false;
  std::uint64_t num_faces = 0;
  // Points the decoder allocates for before decoding: num_points (sequential), or encoded vertices + split symbols
  // (edgebreaker; the decoded point count can differ, and is checked after decoding).
  std::uint64_t num_vertices = 0;
};

Result<DracoHeaderCounts> read_draco_header(const std::uint8_t* data, size_t size);

}  // namespace rgbdcast::glb
