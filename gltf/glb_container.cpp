#include "gltf/glb_container.h"

#include <cstring>

namespace rgbdcast::glb {
namespace {

constexpr std::uint32_t kMagic = 0x46546C67;      // "glTF"
constexpr std::uint32_t kChunkJson = 0x4E4F534A;  // "JSON"
constexpr std::uint32_t kChunkBin = 0x004E4942;   // "BIN\0"

std::uint32_t read_u32(const std::uint8_t* p) {
  return std::uint32_t(p[0]) | (std::uint32_t(p[1]) << 8) | (std::uint32_t(p[2]) << 16) | (std::uint32_t(p[3]) << 24);
}
void put_u32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}
Error bad(const std::string& what) { return make_error(ErrorCode::kInvalidInput, "GLB: " + what); }

}  // namespace

Result<GlbChunks> parse_glb(const std::uint8_t* data, size_t size) {
  if (data == nullptr || size < 12) return bad("shorter than its 12-byte header");
  if (read_u32(data) != kMagic) return bad("not a GLB file (magic is not 'glTF')");
  if (read_u32(data + 4) != 2) return bad("version " + std::to_string(read_u32(data + 4)) + " (only 2 is supported)");
  const std::uint32_t length = read_u32(data + 8);
  if (length > size)
    return bad("truncated: header says " + std::to_string(length) + " bytes, have " + std::to_string(size));
  if (length < 20) return bad("no JSON chunk");
  GlbChunks out;
  size_t pos = 12;
  int chunk = 0;
  while (pos < length) {
    if (length - pos < 8) return bad("truncated chunk header at byte " + std::to_string(pos));
    const std::uint32_t clen = read_u32(data + pos), ctype = read_u32(data + pos + 4);
    pos += 8;
    if (clen > length - pos) return bad("chunk " + std::to_string(chunk) + " runs past the end of the file");
    if (chunk == 0) {
      if (ctype != kChunkJson) return bad("first chunk is not JSON");
      out.json.assign(reinterpret_cast<const char*>(data + pos), clen);
    } else if (chunk == 1 && ctype == kChunkBin) {
      out.bin.assign(data + pos, data + pos + clen);
      out.has_bin = true;
    }  // other chunks: ignored, as the spec asks
    pos += clen;
    pos = (pos + 3) & ~size_t(3);
    ++chunk;
  }
  if (chunk == 0) return bad("no JSON chunk");
  return out;
}

std::vector<std::uint8_t> pack_glb(const std::string& json, const std::vector<std::uint8_t>& bin) {
  std::string j = json;
  while (j.size() % 4) j.push_back(' ');
  std::vector<std::uint8_t> b = bin;
  while (b.size() % 4) b.push_back(0);
  const size_t total = 12 + 8 + j.size() + (b.empty() ? 0 : 8 + b.size());
  std::vector<std::uint8_t> out;
  out.reserve(total);
  put_u32(out, kMagic);
  put_u32(out, 2);
  put_u32(out, static_cast<std::uint32_t>(total));
  put_u32(out, static_cast<std::uint32_t>(j.size()));
  put_u32(out, kChunkJson);
  out.insert(out.end(), j.begin(), j.end());
  if (!b.empty()) {
    put_u32(out, static_cast<std::uint32_t>(b.size()));
    put_u32(out, kChunkBin);
    out.insert(out.end(), b.begin(), b.end());
  }
  return out;
}

}  // namespace rgbdcast::glb
