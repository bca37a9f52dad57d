#pragma once
// GLBs built to attack a decoder, as a hostile client sends them: each starts from a small textured scene written by
// encode_glb (plain: no quantization, no meshopt, so the JSON is easy to edit) and changes one thing.
// Shared by the decoder tests (tests/gltf) and the server tests (tests/service).
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace rgbdcast::test {

using Bytes = std::vector<std::uint8_t>;

Bytes plain_sample_glb();
// Re-packs the GLB with its JSON edited (the BIN chunk kept as it is).
Bytes edit_glb(const Bytes& glb, const std::function<void(nlohmann::json&)>& edit);
// Buffer 0 (the BIN chunk) replaced by a uri: the server-file-read attack.
Bytes glb_with_buffer_uri(const std::string& uri);
// The texture image's bufferView replaced by a uri.
Bytes glb_with_image_uri(const std::string& uri);
// Node 0's extras nested `depth` objects deep ({"a":{"a":...0}}), written as text (nlohmann's dump recurses).
Bytes glb_with_nested_extras(int depth);
// The first POSITION accessor claims `count` elements (its bufferView unchanged).
Bytes glb_with_position_count(std::uint64_t count);
// The first POSITION accessor has no bufferView and claims `count` elements (zeros, per the spec), no indices.
Bytes glb_without_bufferview(std::uint64_t count);
// Node 0 and `copies` more nodes instancing the same mesh.
Bytes glb_with_mesh_instances(int copies);
// The vertex count of the sample's first mesh.
size_t sample_first_mesh_vertices();

}  // namespace rgbdcast::test
