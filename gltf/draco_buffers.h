#pragma once
// KHR_draco_mesh_compression as a pass over a GLB's JSON and BIN chunk (like meshopt_buffers.h for
// EXT_meshopt_compression), after the Khronos extension specification:
//  - compress: each triangle primitive's vertex attributes and indices are encoded as one Draco mesh (bitstream 2.2)
//    in a new bufferView; the primitive's accessors stay, without bufferView, with the decoded count (and POSITION's
//    min/max, of the decoded values); an indices accessor is added to a primitive that had none. The views they used
//    are dropped; other views (images, points) are kept, renumbered. KHR_draco_mesh_compression goes into
//    extensionsUsed and extensionsRequired. Primitives that are not triangle lists, have morph targets or share an
//    accessor with another primitive stay as they are. kInvalidArgument for a file this pass cannot read.
//  - decompress: any GLB using the extension (a hostile upload included) becomes a plain GLB before tinygltf reads
//    it: each Draco primitive's data is decoded into new bufferViews in its accessors' declared component types, the
//    extension is dropped. A malformed file is kInvalidInput ("GLB draco: ...").
//
// Quantization rule (compress, float attributes; Draco quantizes each attribute over its largest per-axis range R
// with step R / (2^bits - 1), so its error is at most half a step):
//  - POSITION: bits = ceil(log2(R / position_step_m + 1)): the smallest count whose step is at most
//    position_step_m (GlbWriteOptions::position_quantum_m, 1 mm by default; a larger value is coarser), capped at 30.
//  - TEXCOORD_n: bits = ceil(log2(R * T / uv_step_texels + 1)), T the larger side in texels of the baseColorTexture
//    that samples it (read from the image's header), so the step is at most uv_step_texels (0.25 texel); 12 bits
//    when no texture samples it. KHR_texture_transform is not taken into account.
//  - other float attributes: 12 bits. Integer attributes (COLOR_0 as normalized uint16) are coded losslessly.
//
// Untrusted input (decompress): before Draco allocates anything, the accessors' declared counts are held to `limits`
// (max_vertices, max_triangles, summed over the file, and max_draco_bytes of decoded data) and the Draco header's
// counts (draco_header.h) to the accessors': num_faces must equal indices.count / 3, and the vertices the decoder
// sizes its tables for may not exceed 3 x num_faces (edgebreaker) or must equal POSITION's count (sequential).
// After decoding, the point and face counts must equal the accessors' counts, and every attribute the extension
// names must exist with the accessor's number of components.
#include "gltf/glb_container.h"
#include "gltf/gltf_io.h"

namespace rgbdcast::glb {

Result<GlbChunks> draco_compress(const GlbChunks& in, const DracoOptions& options);
// Whether the JSON mentions the extension at all (a cheap test before parsing).
bool uses_draco(const GlbChunks& in);
// Returns the input unchanged when the file does not use KHR_draco_mesh_compression.
Result<GlbChunks> draco_decompress(const GlbChunks& in, const GlbDecodeLimits& limits);

}  // namespace rgbdcast::glb
