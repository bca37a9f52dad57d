#pragma once
// glTF 2.0 binary (GLB) in and out, through tinygltf. The scene's world frame uses the camera convention (y down,
// z forward); the GLB's root node carries camera_to_gltf() so that viewers see it upright.
#include <cstdint>
#include <string>
#include <vector>

#include "scene/result.h"
#include "scene/scene.h"

namespace rgbdcast {

struct GlbWriteOptions {
  int jpeg_quality = 85;  // atlas texture JPEG quality (1..100)
  std::string generator = "rgbdcast";
};

// Encodes a scene as GLB bytes. Textures are written from Mesh::texture_encoded when present, else encoded as JPEG.
Result<std::vector<std::uint8_t>> encode_glb(const Scene& scene, const GlbWriteOptions& options = {});
// Writes atomically: a temporary file beside `path`, fsync, rename. Nothing is left behind on failure.
Status write_glb_file(const Scene& scene, const std::string& path, const GlbWriteOptions& options = {});

// Decodes GLB bytes from an untrusted source: any GLB rgbdcast writes and ordinary textured-mesh GLBs. Textures are
// decoded to Mesh::texture (RGB8). A truncated or malformed file is an kInvalidInput error, never a crash.
Result<Scene> decode_glb(const std::uint8_t* data, size_t size);
Result<Scene> read_glb_file(const std::string& path);

}  // namespace rgbdcast
