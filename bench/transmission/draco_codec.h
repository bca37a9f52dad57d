#pragma once
// Draco point cloud coding, isolated in its own shared library (transmission_draco). Debian's libdraco carries its
// own copy of tinygltf (another version) for its glTF reader, and its inline tinygltf functions interpose the ones
// libtinygltf.so and rgbdcast_gltf use: decode_glb then crashes in tinygltf::Model::~Model, whether libdraco is
// linked shared (its weak tinygltf symbols are exported) or static into the program (the linker may keep draco's
// copy of an inline function). This library links libdraco.a with --exclude-libs,ALL and exports only these two
// functions, so none of draco's symbols are visible to the rest of the program.
#include <cstdint>
#include <string>
#include <vector>

namespace rgbdcast::bench {

// positions: 3 floats a point; colors: 3 bytes a point. Default speed (5/5, the k-d tree coder), positions
// quantized to position_bits, colour stored as uint8 (8 bits, not quantized further). Empty + error on failure.
std::vector<std::uint8_t> draco_encode_points(const std::vector<float>& positions,
                                              const std::vector<std::uint8_t>& colors, int position_bits,
                                              std::string* error);
// Fills positions / colors (3 a point); false + error on a malformed buffer.
bool draco_decode_points(const std::uint8_t* data, size_t size, std::vector<float>* positions,
                         std::vector<std::uint8_t>* colors, std::string* error);

}  // namespace rgbdcast::bench
