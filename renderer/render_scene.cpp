#include "renderer/render_scene.h"

#define STB_IMAGE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_JPEG
#define STBI_ONLY_PNG
#include <stb/stb_image.h>

#include <cmath>
#include <cstring>
#include <limits>

namespace rgbdcast {
namespace {

constexpr int kMaxTextureSize = 16384;  // what lavapipe and llvmpipe sample

Result<Image> to_rgba(const Mesh& mesh, const std::string& what) {
  Image rgba;
  if (!mesh.texture.empty()) {
    const Image& t = mesh.texture;
    if ((t.channels != 3 && t.channels != 4) || t.data.size() != static_cast<size_t>(t.width) * t.height * t.channels)
      return make_error(ErrorCode::kInvalidInput, what + ": texture size does not match its pixel data");
    if (t.width > kMaxTextureSize || t.height > kMaxTextureSize)
      return make_error(ErrorCode::kInvalidInput, what + ": texture larger than " + std::to_string(kMaxTextureSize));
    rgba = Image::make(t.width, t.height, 4);
    for (size_t i = 0, n = static_cast<size_t>(t.width) * t.height; i < n; ++i) {
      for (int c = 0; c < 3; ++c) rgba.data[i * 4 + c] = t.data[i * t.channels + c];
      rgba.data[i * 4 + 3] = 255;
    }
    return rgba;
  }
  if (mesh.texture_encoded.size() > static_cast<size_t>(std::numeric_limits<int>::max()))
    return make_error(ErrorCode::kInvalidInput, what + ": encoded texture too large");
  int w = 0, h = 0, n = 0;
  stbi_uc* px =
      stbi_load_from_memory(mesh.texture_encoded.data(), static_cast<int>(mesh.texture_encoded.size()), &w, &h, &n, 4);
  if (!px) return make_error(ErrorCode::kInvalidInput, what + ": cannot decode texture (" + mesh.texture_mime + ")");
  if (w > kMaxTextureSize || h > kMaxTextureSize) {
    stbi_image_free(px);
    return make_error(ErrorCode::kInvalidInput, what + ": texture larger than " + std::to_string(kMaxTextureSize));
  }
  rgba = Image::make(w, h, 4);
  std::copy(px, px + static_cast<size_t>(w) * h * 4, rgba.data.begin());
  stbi_image_free(px);
  return rgba;
}

GpuVertex make_vertex(const Eigen::Vector3f& p, const Eigen::Vector2f* uv, const Rgb8* color) {
  GpuVertex v{};
  v.position[0] = p.x();
  v.position[1] = p.y();
  v.position[2] = p.z();
  if (uv) {
    v.uv[0] = uv->x();
    v.uv[1] = uv->y();
  }
  v.color[3] = 255;
  if (color)
    for (int c = 0; c < 3; ++c) v.color[c] = (*color)[c];
  return v;
}

}  // namespace

Result<PreparedScene> prepare_scene(const Scene& scene) {
  PreparedScene out;
  for (size_t ni = 0; ni < scene.nodes.size(); ++ni) {
    const SceneNode& node = scene.nodes[ni];
    const std::string what = "scene node " + std::to_string(ni) + (node.name.empty() ? "" : " '" + node.name + "'");
    if (!node.to_world.allFinite())
      return make_error(ErrorCode::kInvalidInput, what + ": transform contains NaN or infinite values");
    PreparedNode pn;
    pn.name = node.name;
    pn.to_world = node.to_world;

    const Mesh& m = node.mesh;
    const size_t nv = m.positions.size();
    if (!m.uvs.empty() && m.uvs.size() != nv)
      return make_error(ErrorCode::kInvalidInput,
                        what + ": " + std::to_string(m.uvs.size()) + " uvs for " + std::to_string(nv) + " positions");
    if (!m.colors.empty() && m.colors.size() != nv)
      return make_error(ErrorCode::kInvalidInput, what + ": " + std::to_string(m.colors.size()) + " colours for " +
                                                      std::to_string(nv) + " positions");
    if (m.indices.size() % 3 != 0)
      return make_error(ErrorCode::kInvalidInput, what + ": index count is not a multiple of 3");
    for (std::uint32_t i : m.indices)
      if (i >= nv)
        return make_error(ErrorCode::kInvalidInput, what + ": index " + std::to_string(i) + " out of range (" +
                                                        std::to_string(nv) + " vertices)");
    const bool has_texture = !m.uvs.empty() && (!m.texture.empty() || !m.texture_encoded.empty());
    const bool has_colors = !m.colors.empty();
    const bool draws_mesh_vertices = nv > 0 && (!m.indices.empty() || node.points.size() == 0);
    if (draws_mesh_vertices && !has_texture && !has_colors)
      return make_error(ErrorCode::kInvalidInput, what + ": mesh has no texture and no vertex colours");
    if (nv > 0) {
      pn.mesh_vertices.reserve(nv);
      for (size_t i = 0; i < nv; ++i)
        pn.mesh_vertices.push_back(
            make_vertex(m.positions[i], m.uvs.empty() ? nullptr : &m.uvs[i], has_colors ? &m.colors[i] : nullptr));
      pn.indices = m.indices;
      pn.mesh_colors = has_texture ? ColorSource::kTextureFragment : ColorSource::kVertex;
      // Points of a mesh: captured colours when there are any, else the texture at the vertex uv.
      pn.point_colors = has_colors ? ColorSource::kVertex : ColorSource::kTextureVertex;
    }
    if (has_texture) {
      auto tex = to_rgba(m, what);
      if (!tex) return tex.error();
      pn.texture = std::move(tex.value());
    }

    const PointCloud& pc = node.points;
    if (pc.size() > 0) {
      if (pc.colors.size() != pc.size())
        return make_error(ErrorCode::kInvalidInput, what + ": " + std::to_string(pc.colors.size()) +
                                                        " point colours for " + std::to_string(pc.size()) + " points");
      pn.point_vertices.reserve(pc.size());
      for (size_t i = 0; i < pc.size(); ++i)
        pn.point_vertices.push_back(make_vertex(pc.positions[i], nullptr, &pc.colors[i]));
      pn.point_colors = ColorSource::kVertex;
    }
    out.triangle_count += pn.indices.size() / 3;
    out.point_count += pn.point_vertices.empty() ? pn.mesh_vertices.size() : pn.point_vertices.size();
    if (!pn.mesh_vertices.empty() || !pn.point_vertices.empty()) out.nodes.push_back(std::move(pn));
  }
  if (out.triangle_count == 0 && out.point_count == 0)
    return make_error(ErrorCode::kEmpty, "scene is empty: no triangles and no points to draw");
  return out;
}

DrawParams make_draw_params(const Eigen::Matrix4d& clip_from_node, float point_size_px, ColorSource source) {
  DrawParams p{};
  const Eigen::Matrix4f m = clip_from_node.cast<float>();
  std::memcpy(p.clip_from_node, m.data(), sizeof(p.clip_from_node));  // Eigen is column-major, like GLSL
  p.params[0] = point_size_px;
  p.params[1] = static_cast<float>(static_cast<int>(source));
  return p;
}

}  // namespace rgbdcast
