#include "reduction/mesh_edges.h"

#include <algorithm>

namespace rgbdcast {

// Edges bucketed by their lower vertex (a counting sort), then compared within each bucket: a vertex of a triangle
// mesh is the lower end of a few edges (6 on average, in each direction), so a bucket is compared pairwise. Each
// slot's upper end is stored beside it in its bucket, so the comparisons read one contiguous run.
std::vector<std::uint32_t> edge_use_counts(const std::vector<std::uint32_t>& indices, size_t vertex_count) {
  const size_t slots = indices.size() - indices.size() % 3;
  std::vector<std::uint32_t> lo(slots), hi(slots);
  for (size_t t = 0; t < slots; t += 3)
    for (size_t e = 0; e < 3; ++e) {
      const std::uint32_t a = indices[t + e], b = indices[t + (e == 2 ? 0 : e + 1)];
      lo[t + e] = std::min(a, b), hi[t + e] = std::max(a, b);
    }
  std::vector<std::uint32_t> start(vertex_count + 1, 0);
  for (size_t s = 0; s < slots; ++s) ++start[lo[s] + 1];
  for (size_t v = 0; v < vertex_count; ++v) start[v + 1] += start[v];
  std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
  struct Entry {
    std::uint32_t upper, slot;
  };
  std::vector<Entry> bucket(slots);  // slots by lower vertex
  for (size_t s = 0; s < slots; ++s) bucket[fill[lo[s]]++] = {hi[s], static_cast<std::uint32_t>(s)};
  std::vector<std::uint32_t> uses(slots, 1);
  for (size_t v = 0; v < vertex_count; ++v) {
    const Entry* b = bucket.data() + start[v];
    const size_t n = start[v + 1] - start[v];
    for (size_t i = 0; i < n; ++i)
      for (size_t j = i + 1; j < n; ++j)
        if (b[i].upper == b[j].upper) ++uses[b[i].slot], ++uses[b[j].slot];
  }
  return uses;
}

}  // namespace rgbdcast
