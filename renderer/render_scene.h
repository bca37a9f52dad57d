#pragma once
// A Scene turned into what both backends upload: per node, interleaved vertices, triangle indices, an RGBA8 texture
// and where points-mode colours come from. Checks the scene as untrusted input (it may come from a GLB off the
// network), so the backends never read out of bounds.
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "scene/image.h"
#include "scene/result.h"
#include "scene/scene.h"

namespace rgbdcast {

// Matches the vertex inputs of shaders/scene.vert (locations 0, 1, 2). 24 bytes.
struct GpuVertex {
  float position[3];
  float uv[2];
  std::uint8_t color[4];
};
static_assert(sizeof(GpuVertex) == 24);

// color_source of shaders/scene.vert.
enum class ColorSource : int { kVertex = 0, kTextureFragment = 1, kTextureVertex = 2 };

// The DrawParams block of shaders/scene.vert, one per draw: Vulkan's push constants and OpenGL's std140 uniform
// block have this same layout. 80 bytes.
struct DrawParams {
  float clip_from_node[16];  // column-major, as GLSL's mat4
  float params[4];           // x: point size in pixels, y: the ColorSource, z and w: unused (0)
};
static_assert(sizeof(DrawParams) == 80);

// A draw's parameters: the node's clip-from-node transform (clip-from-world times the node's to_world), the point
// size and where its colours come from.
DrawParams make_draw_params(const Eigen::Matrix4d& clip_from_node, float point_size_px, ColorSource source);

struct PreparedNode {
  std::string name;
  Eigen::Matrix4d to_world = Eigen::Matrix4d::Identity();
  std::vector<GpuVertex> mesh_vertices;  // empty when the node has no triangles
  std::vector<std::uint32_t> indices;
  ColorSource mesh_colors = ColorSource::kVertex;
  std::vector<GpuVertex> point_vertices;  // the node's points; or empty: points mode then draws mesh_vertices
  ColorSource point_colors = ColorSource::kVertex;
  Image texture;  // RGBA8; empty when no draw of this node samples a texture
};

struct PreparedScene {
  std::vector<PreparedNode> nodes;
  size_t triangle_count = 0, point_count = 0;
};

// Fails with kEmpty when there is nothing to draw (no triangles and no points), kInvalidInput on an index out of
// range, a triangle list not a multiple of 3, uvs/colours whose count differs from the positions, a non-finite
// node transform or an undecodable texture. A node whose uvs have no texture (or a texture with no uvs) is drawn with
// its vertex colours; with no vertex colours either it fails with kInvalidInput ("... has no texture and no vertex
// colours"). Mesh::texture_encoded is decoded (JPEG/PNG) when Mesh::texture is empty.
Result<PreparedScene> prepare_scene(const Scene& scene);

}  // namespace rgbdcast
