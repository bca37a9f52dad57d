#pragma once
// EXT_meshopt_compression as a pass over a GLB's JSON and BIN chunk.
//  - compress: every bufferView holding a mesh primitive's vertex attribute (must have byteStride) or indices is
//    encoded with meshoptimizer's vertex codec (mode ATTRIBUTES) or index codec (TRIANGLES for triangle lists,
//    INDICES otherwise) into buffer 0 (the BIN chunk); the uncompressed views move to a fallback buffer without data
//    (buffer 1, "fallback": true), as the extension specifies. Other views (images) are copied unchanged.
//  - decompress: the inverse, for any GLB using the extension with its compressed data in the BIN chunk: decoded
//    views are appended to the BIN chunk, fallback buffers are removed, and the extension is dropped, so the result
//    is a plain GLB. Decoders are bounds-checked (meshoptimizer's decoders are safe on untrusted input); sizes are
//    checked before allocation. A malformed file is kInvalidInput.
#include "gltf/glb_container.h"

namespace rgbdcast::glb {

Result<GlbChunks> meshopt_compress(const GlbChunks& in);
// Whether the JSON mentions the extension at all (a cheap test before a copy).
bool uses_meshopt(const GlbChunks& in);
// Returns the input unchanged when the file does not use EXT_meshopt_compression. The decoded bytes are bounded by
// max_decoded_bytes (summed over the file) and by the sizes the file declares, checked before allocating.
Result<GlbChunks> meshopt_decompress(const GlbChunks& in, size_t max_decoded_bytes = size_t(128) << 20);

}  // namespace rgbdcast::glb
