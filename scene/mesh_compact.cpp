#include "scene/mesh_compact.h"

#include <utility>

namespace rgbdcast {

Mesh compact_mesh(Mesh&& in, const std::vector<std::uint32_t>& indices) {
  std::vector<std::int64_t> remap(in.positions.size(), -1);
  Mesh out;
  out.indices.reserve(indices.size());
  for (std::uint32_t i : indices) {
    if (remap[i] < 0) {
      remap[i] = static_cast<std::int64_t>(out.positions.size());
      out.positions.push_back(in.positions[i]);
      if (!in.uvs.empty()) out.uvs.push_back(in.uvs[i]);
      if (!in.colors.empty()) out.colors.push_back(in.colors[i]);
    }
    out.indices.push_back(static_cast<std::uint32_t>(remap[i]));
  }
  out.texture = std::move(in.texture);
  out.texture_encoded = std::move(in.texture_encoded);
  out.texture_mime = std::move(in.texture_mime);
  return out;
}

}  // namespace rgbdcast
