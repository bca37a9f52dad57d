#pragma once
// How many triangles share each triangle's edges, in time linear in the mesh (no sort of every edge): the realtime
// preset asks this of every mesh it extracts (boundary vertices are pushed outwards) and collapses (outline
// vertices may move; edges left with three triangles by a fold are repaired).
#include <cstddef>
#include <cstdint>
#include <vector>

namespace rgbdcast {

// indices: triangles as vertex ids below vertex_count. For each edge slot s (edge e of triangle t is slot 3t + e,
// from vertex indices[3t + e] to indices[3t + (e + 1) % 3]) the number of slots, itself included, that join the
// same two vertices in either direction: 1 on a boundary, 2 inside a manifold mesh, 3 or more on a non-manifold edge.
std::vector<std::uint32_t> edge_use_counts(const std::vector<std::uint32_t>& indices, size_t vertex_count);

}  // namespace rgbdcast
