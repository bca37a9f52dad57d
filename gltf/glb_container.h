#pragma once
// The GLB container (glTF 2.0 binary, section 4.4): a 12-byte header, a JSON chunk, an optional BIN chunk.
// parse_glb checks every length against the input before reading (hostile input); pack_glb pads the JSON with spaces
// and the BIN chunk with zeros to 4 bytes.
#include <cstdint>
#include <string>
#include <vector>

#include "scene/result.h"

namespace rgbdcast::glb {

struct GlbChunks {
  std::string json;
  std::vector<std::uint8_t> bin;  // empty when the file has no BIN chunk
  bool has_bin = false;
};

Result<GlbChunks> parse_glb(const std::uint8_t* data, size_t size);
std::vector<std::uint8_t> pack_glb(const std::string& json, const std::vector<std::uint8_t>& bin);

}  // namespace rgbdcast::glb
