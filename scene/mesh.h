#pragma once
// The geometry that flows from the reduction to the renderer: a triangle mesh with an optional texture, and a
// coloured point cloud for splat rendering. Positions are metres in the frame of the node that holds them.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "scene/image.h"

namespace rgbdcast {

using Rgb8 = std::array<std::uint8_t, 3>;

struct Mesh {
  std::vector<Eigen::Vector3f> positions;
  std::vector<Eigen::Vector2f> uvs;    // one per position, texture space with (0,0) the top-left corner; or empty
  std::vector<Rgb8> colors;            // one per position; or empty
  std::vector<std::uint32_t> indices;  // three per triangle, counter-clockwise seen from the capture camera
  Image texture;                       // RGB8 base colour; empty when the mesh is vertex-coloured
  std::vector<std::uint8_t> texture_encoded;  // the texture as stored (JPEG/PNG bytes), when it came from a file
  std::string texture_mime;                   // "image/jpeg" or "image/png" for texture_encoded

  size_t triangle_count() const { return indices.size() / 3; }
  bool textured() const { return !uvs.empty() && (!texture.empty() || !texture_encoded.empty()); }
};

struct PointCloud {
  std::vector<Eigen::Vector3f> positions;
  std::vector<Rgb8> colors;  // one per position
  size_t size() const { return positions.size(); }
};

}  // namespace rgbdcast
