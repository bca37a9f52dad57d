#include "gltf/draco_header.h"

#include <cstring>

namespace rgbdcast::glb {
namespace {

Error bad(const std::string& what) { return make_error(ErrorCode::kInvalidInput, "GLB draco: " + what); }

class Reader {
 public:
  Reader(const std::uint8_t* d, size_t n, size_t at) : d_(d), n_(n), at_(at) {}
  bool u8(std::uint32_t* v) {
    if (at_ >= n_) return false;
    *v = d_[at_++];
    return true;
  }
  // Draco's varint: 7 bits a byte, low bits first, the top bit says more follow; at most 5 bytes for 32 bits.
  bool varint(std::uint32_t* v) {
    std::uint64_t value = 0;
    for (int i = 0; i < 5; ++i) {
      std::uint32_t b;
      if (!u8(&b)) return false;
      value |= std::uint64_t(b & 0x7f) << (7 * i);
      if (!(b & 0x80)) {
        if (value > 0xffffffffu) return false;
        *v = static_cast<std::uint32_t>(value);
        return true;
      }
    }
    return false;
  }

 private:
  const std::uint8_t* d_;
  size_t n_, at_;
};

}  // namespace

Result<DracoHeaderCounts> read_draco_header(const std::uint8_t* data, size_t size) {
  if (size < 11 || std::memcmp(data, "DRACO", 5) != 0) return bad("data is not a Draco bitstream");
  const std::uint32_t major = data[5], minor = data[6], type = data[7], method = data[8];
  const std::uint32_t flags = data[9] | (std::uint32_t(data[10]) << 8);
  if (major != 2 || minor != 2)
    return bad("Draco bitstream " + std::to_string(major) + "." + std::to_string(minor) + " (only 2.2 is accepted)");
  if (type != 1) return bad("Draco data is not a triangle mesh");
  if (flags & 0x8000) return bad("Draco metadata is not accepted");
  Reader r(data, size, 11);
  DracoHeaderCounts c;
  std::uint32_t faces = 0, vertices = 0;
  if (method == 0) {
    if (!r.varint(&faces) || !r.varint(&vertices)) return bad("Draco header cut short");
  } else if (method == 1) {
    std::uint32_t traversal, attribute_data, symbols, split;
    if (!r.u8(&traversal) || !r.varint(&vertices) || !r.varint(&faces) || !r.u8(&attribute_data) ||
        !r.varint(&symbols) || !r.varint(&split))
      return bad("Draco header cut short");
    c.edgebreaker = true;
    c.num_vertices = std::uint64_t(vertices) + split;
  } else {
    return bad("unknown Draco encoding method " + std::to_string(method));
  }
  c.num_faces = faces;
  if (!c.edgebreaker) c.num_vertices = vertices;
  return c;
}

}  // namespace rgbdcast::glb
