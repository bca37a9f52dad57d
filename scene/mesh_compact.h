#pragma once
// Keeping some of a mesh's triangles: what the coverage filters (reduction/coverage_filter.h, tiles/tile_cover.h) do
// once they know which triangles another view saw.
#include <cstdint>
#include <vector>

#include "scene/mesh.h"

namespace rgbdcast {

// The mesh of the triangles `indices` lists (three per triangle, indexing in's vertices): a vertex no listed triangle
// uses is dropped with its uv and colour, the others renumbered in order of first use; the texture moves along.
Mesh compact_mesh(Mesh&& in, const std::vector<std::uint32_t>& indices);

}  // namespace rgbdcast
