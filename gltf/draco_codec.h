#pragma once
// Draco mesh coding behind a small, std-only interface, built as its own shared library (rgbdcast_draco) that links
// Debian's libdraco.a with hidden visibility and --exclude-libs,ALL. Debian's libdraco carries its own tinygltf
// (another version); linked any other way its inline tinygltf functions interpose the ones rgbdcast_gltf uses and
// decode_glb crashes in tinygltf::Model::~Model (STACK.md). Only the two functions below are exported, and only
// gltf/draco_buffers.cpp calls them.
//
// Contract: both functions are pure (no shared state, thread-safe), never throw (Draco's exceptions, bad_alloc
// included, become an error string), and report failure as an empty result with *error set to one line.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace rgbdcast::draco_codec {

// One vertex attribute of the mesh to encode, num_points values. component_type is a glTF componentType (5120 BYTE,
// 5121 UNSIGNED_BYTE, 5122 SHORT, 5123 UNSIGNED_SHORT, 5125 UNSIGNED_INT, 5126 FLOAT). Float attributes are
// quantized to quantization_bits (1..30) over their range (Draco's rule: step = largest per-axis range /
// (2^bits - 1)); integer attributes are coded losslessly (quantization_bits ignored).
struct AttributeIn {
  enum class Semantic { kPosition, kTexCoord, kColor, kNormal, kGeneric };
  Semantic semantic = Semantic::kGeneric;
  int component_type = 5126;
  int components = 3;  // 1..4
  bool normalized = false;
  const void* data = nullptr;  // num_points x components, tightly packed
  int quantization_bits = 0;
};

struct MeshIn {
  size_t num_points = 0;
  const std::uint32_t* indices = nullptr;  // num_indices, a triangle list, each < num_points
  size_t num_indices = 0;
  std::vector<AttributeIn> attributes;
  int encode_speed = 7, decode_speed = 7;  // Draco's 0 (smallest) .. 10 (fastest)
};

struct Encoded {
  std::vector<std::uint8_t> bytes;  // the Draco bitstream (2.2); empty on failure
  std::vector<int> attribute_ids;   // Draco unique id of each MeshIn attribute, in order
  // What a decoder gets back, without decoding: the points and faces (the encoder's tracked properties), and for a
  // quantized float POSITION attribute the per-component least and largest decoded value (the input's extremes through
  // Draco's own quantizer and dequantizer, with the parameters the encoder computes: quantization is monotone, so
  // they are the decoded extremes whenever every point is referenced). Empty vectors for other attributes.
  size_t num_points = 0, num_faces = 0;
  std::vector<std::vector<float>> decoded_min, decoded_max;  // per MeshIn attribute
};

Encoded encode_mesh(const MeshIn& mesh, std::string* error);

// What the caller wants back of one attribute: the Draco unique id, and the glTF type to convert the values to.
struct AttributeRequest {
  int unique_id = 0;
  int component_type = 5126;
  int components = 3;
};

struct Decoded {
  size_t num_points = 0;
  std::vector<std::uint32_t> indices;                 // 3 per face, each < num_points
  std::vector<std::vector<std::uint8_t>> attributes;  // per request: num_points x components, tightly packed
};

// Decodes a Draco mesh bitstream. The caller bounds the allocation before calling (gltf/draco_header.h reads the
// counts from the bitstream); this function checks again after decoding: more than max_points points or
// max_faces faces, an attribute that is missing or has another number of components, or an index out of range is
// an error. Returns false with *error on any failure.
bool decode_mesh(const std::uint8_t* data, size_t size, const std::vector<AttributeRequest>& requests,
                 size_t max_points, size_t max_faces, Decoded* out, std::string* error);

}  // namespace rgbdcast::draco_codec
