#include "scene/render_bytes.h"

#include "scene/image_probe.h"

namespace rgbdcast {

size_t render_bytes(const Mesh& mesh) {
  size_t bytes = mesh.positions.size() * 24 + mesh.indices.size() * 4;
  if (!mesh.texture.empty()) {
    bytes += static_cast<size_t>(mesh.texture.width) * mesh.texture.height * 4;
  } else if (int w = 0, h = 0; !mesh.texture_encoded.empty() &&
                               probe_image_size(mesh.texture_encoded.data(), mesh.texture_encoded.size(), &w, &h)) {
    bytes += static_cast<size_t>(w) * static_cast<size_t>(h) * 4;
  }
  return bytes;
}

size_t render_bytes(const Scene& scene) {
  size_t bytes = 0;
  for (const SceneNode& node : scene.nodes) bytes += render_bytes(node.mesh) + node.points.positions.size() * 24;
  return bytes;
}

}  // namespace rgbdcast
