#include "reduction/mesh_edges.h"

#include <algorithm>

namespace rgbdcast {

// Edges bucketed by their lower vertex (a counting sort), then compared within each bucket: a vertex of a triangle
// mesh is the lower end of a few edges (6 on average, in each direction), so a bucket is compared pairwise.
std::vector<std::uint32_t> edge_use_counts(const std::vector<std::uint32_t>& indices, size_t vertex_count) {
  const size_t slots = indices.size() - indices.size() % 3;
  std::vector<std::uint32_t> start(vertex_count + 1, 0);
  auto ends = [&](size_t s) {
    const size_t t = s - s % 3;
    const std::uint32_t a = indices[s], b = indices[t + (s - t + 1) % 3];
    return std::pair<std::uint32_t, std::uint32_t>{std::min(a, b), std::max(a, b)};
  };
  for (size_t s = 0; s < slots; ++s) ++start[ends(s).first + 1];
  for (size_t v = 0; v < vertex_count; ++v) start[v + 1] += start[v];
  std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
  std::vector<std::uint32_t> bucket(slots);  // slots by lower vertex
  for (size_t s = 0; s < slots; ++s) bucket[fill[ends(s).first]++] = static_cast<std::uint32_t>(s);
  std::vector<std::uint32_t> uses(slots, 1);
  for (size_t v = 0; v < vertex_count; ++v) {
    const std::uint32_t* b = bucket.data() + start[v];
    const size_t n = start[v + 1] - start[v];
    for (size_t i = 0; i < n; ++i)
      for (size_t j = i + 1; j < n; ++j)
        if (ends(b[i]).second == ends(b[j]).second) ++uses[b[i]], ++uses[b[j]];
  }
  return uses;
}

}  // namespace rgbdcast
