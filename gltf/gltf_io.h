#pragma once
// glTF 2.0 binary (GLB) in and out, through tinygltf. The scene's world frame uses the camera convention (y down,
// z forward); the GLB's root node carries camera_to_gltf() so that viewers see it upright.
//
// Axis convention, written down (tested in tests/gltf/test_gltf_axes.cpp):
//  - scene world / camera frame: x right, y down, z forward (OpenCV). glTF: x right, y up, the camera looks along -z.
//  - C = camera_to_gltf() = diag(1, -1, -1) (its own inverse). The root node "rgbdcast_world" has matrix C; every
//    SceneNode is a child with matrix to_world. So a scene-world point p appears in glTF world at C p.
//  - A capture camera becomes a glTF perspective camera on a child node of the root with local matrix
//    camera_to_world * C; its glTF world matrix is C camera_to_world C. A point at depth d straight ahead of the
//    capture camera (camera frame (0, 0, d)) is at (0, 0, -d) in the glTF camera node's frame: in front of it.
//  - yfov = 2 atan(height / (2 fy)), aspectRatio = width / height. glTF cameras have no principal point or fx != fy;
//    the exact intrinsics travel in the camera node's extras ("rgbdcast_camera") and the reader restores them.
//  - Reading: SceneNode::to_world = C * (glTF world matrix of the node); CaptureCamera::camera_to_world =
//    C * (glTF world matrix of the camera node) * C. Files from elsewhere are read with the same rule.
//
// What is written: per SceneNode a node (matrix to_world) with one child per geometry: triangles (POSITION,
// TEXCOORD_0 or COLOR_0, 16-bit indices when the vertices fit), points (mode 0, POSITION + COLOR_0). Materials are
// KHR_materials_unlit with baseColorTexture (JPEG or PNG in a bufferView with mimeType), double-sided, sampled with
// LINEAR filters and CLAMP_TO_EDGE (no mipmaps: atlas cells would bleed into each other). COLOR_0 is linear (glTF)
// and stored as normalized uint16; the reader converts it back to sRGB bytes. Scene::extras_json goes into the glTF
// scene's extras. With `quantize`, KHR_mesh_quantization: positions as int16 with the dequantization (translation +
// uniform scale) on the geometry's child node; UVs that all sit on texel corners (the atlas) as uint16 texel
// coordinates with KHR_texture_transform scale (1/width, 1/height) on the baseColorTexture, other UVs in [0,1] as
// uint16 in 1/8 texel (scale 1/(8 width), 1/(8 height)). A triangle list whose indices are 0, 1, 2, ... (the atlas
// mesh) is written without indices. With `meshopt`, EXT_meshopt_compression (vertex and index codecs) on top. With
// geometry_codec kDraco instead, float POSITION and TEXCOORD_0 (no KHR_mesh_quantization, no texture transform)
// compressed by KHR_draco_mesh_compression.
//
// Two flavours of the same scene (GlbFlavor):
//  - compact, the wire format: quantization and meshopt as GlbWriteOptions says (both on by default). Opens in
//    viewers that ship a meshopt decoder (three.js with MeshoptDecoder set; tested in tests/gltf/test_gltf_viewers).
//  - compat, for every viewer: float POSITION and TEXCOORD_0, float COLOR_0, no EXT_meshopt_compression, no
//    KHR_mesh_quantization, no KHR_texture_transform, every texture a JPEG. `quantize` and `meshopt` are ignored.
//    Opens in Blender 3.4, Assimp 5.2.5 and three.js. Neither Blender 3.4 nor Assimp 5.2.5 reads meshopt; Assimp
//    5.2.5 also ignores KHR_mesh_quantization: it takes int16 POSITION bytes as floats (zeros, NaN, 1e38), its
//    post-processing then drops every triangle, and the import fails with "No meshes remaining".
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "scene/camera.h"  // kMaxImageSize
#include "scene/result.h"
#include "scene/scene.h"

namespace rgbdcast {

enum class GlbFlavor { kCompact, kCompat };
const char* to_string(GlbFlavor flavor);  // "compact", "compat"
// "compact" or "compat"; anything else is kInvalidArgument with a message naming both.
Result<GlbFlavor> parse_glb_flavor(std::string_view name);

// Geometry compression of the compact flavour. meshopt: KHR_mesh_quantization + EXT_meshopt_compression (the
// default; ~4.5 B a triangle on a realtime frame). draco: KHR_draco_mesh_compression (float attributes quantized by
// Draco after the rule in gltf/draco_buffers.h; ~2.6 B a triangle, ~3.5 ms more CPU to encode a realtime frame;
// three.js reads it with DRACOLoader; Debian's Blender 3.4 cannot, Assimp 5.2.5 only partly: README.md).
enum class GeometryCodec { kMeshopt, kDraco };
const char* to_string(GeometryCodec codec);  // "meshopt", "draco"
// "meshopt" or "draco"; anything else is kInvalidArgument naming both.
Result<GeometryCodec> parse_geometry_codec(std::string_view name);

// Draco results of primitives already compressed, keyed by a hash of their input (attribute bytes and types,
// indices, quantization, speeds): a caller that encodes the same mesh twice (a byte budget measures its geometry,
// then the GLB is written with its extras) compresses it once. Not process-wide: whoever wants one makes it and
// passes it in DracoOptions::cache; it keeps the last few entries. Thread-safe.
class DracoCache {
 public:
  struct Entry {
    std::vector<std::uint8_t> bytes;  // the bitstream
    std::vector<int> attribute_ids;
    size_t num_points = 0, num_indices = 0;
    std::vector<double> position_min, position_max;  // of the decoded POSITION values
  };
  std::shared_ptr<const Entry> find(std::uint64_t key) const;
  void put(std::uint64_t key, std::shared_ptr<const Entry> entry);
  size_t hits() const;  // finds that answered

 private:
  static constexpr size_t kKeep = 4;
  mutable std::mutex mutex_;
  mutable size_t hits_ = 0;
  std::vector<std::pair<std::uint64_t, std::shared_ptr<const Entry>>> entries_;  // newest last
};

// KHR_draco_mesh_compression settings (gltf/draco_buffers.h has the quantization rule).
struct DracoOptions {
  double position_step_m = 0.001;  // POSITION step at most this (set from GlbWriteOptions::position_quantum_m)
  double uv_step_texels = 0.25;    // TEXCOORD step at most this many texels of the texture it samples
  // Draco's speed, 0 (smallest, slowest) .. 10; 7 measured best for the realtime preset (BENCHMARKS.md: Draco).
  int encode_speed = 7;
  int decode_speed = 7;
  std::shared_ptr<DracoCache> cache;  // optional: reuse (and keep) the compressed primitives
};

struct GlbWriteOptions {
  GlbFlavor flavor = GlbFlavor::kCompact;  // compat overrides quantize and meshopt (see the top of this file)
  int jpeg_quality = 85;                   // used only for meshes with pixels but no texture_encoded (1..100)
  std::string generator = "rgbdcast";
  bool quantize = true;  // KHR_mesh_quantization (Khronos validator accepts it; three.js reads it)
  // EXT_meshopt_compression: the Khronos validator 2.0.0-dev.3.10 accepts the file (0 errors/warnings; the extension
  // is an info "unsupported") but cannot look inside; three.js reads it with its MeshoptDecoder, decode_glb reads it.
  // Viewers without a meshopt decoder cannot open such files: turn it off for them.
  bool meshopt = true;
  // Quantization step for positions (grows if the extent needs it). 1 mm: max error 0.5 mm, far below the Kinect's
  // depth noise and the 1 cm voxel grid; 2 mm saves another ~20 % of the atlas geometry (bench/atlas_bench).
  double position_quantum_m = 0.001;
  // compact only: kDraco replaces quantize + meshopt with KHR_draco_mesh_compression (compat ignores it).
  GeometryCodec geometry_codec = GeometryCodec::kMeshopt;
  DracoOptions draco;  // its position_step_m is taken from position_quantum_m
};

// Where the bytes of a GLB went.
struct GlbStats {
  size_t geometry_bytes = 0;  // vertex and index bufferViews, as stored (compressed when meshopt)
  size_t texture_bytes = 0;   // encoded images
  size_t json_bytes = 0;
  size_t total_bytes = 0;
  double ms = 0.0;  // encoding time, including any JPEG encoding
};

// Encodes a scene as GLB bytes. Textures are written from Mesh::texture_encoded when present, else encoded as JPEG.
// kInvalidArgument for inconsistent meshes (index out of range, sizes that disagree, non-finite numbers),
// bad intrinsics or extras_json that is not a JSON object.
Result<std::vector<std::uint8_t>> encode_glb(const Scene& scene, const GlbWriteOptions& options = {},
                                             GlbStats* stats = nullptr);
// Writes atomically: a temporary file beside `path`, fsync, rename. Nothing is left behind on failure.
Status write_glb_file(const Scene& scene, const std::string& path, const GlbWriteOptions& options = {},
                      GlbStats* stats = nullptr);

// What decode_glb accepts from an untrusted client. Every limit is checked against the bytes present before the
// decoder allocates for them. The defaults fit any scene rgbdcast writes with margin (the paper's full, unreduced
// 640x480 cloud is 307k vertices and 406k triangles; a reduced frame 22k / 40k) and bound one decode to a few hundred
// MB in the worst case.
struct GlbDecodeLimits {
  size_t max_json_bytes = size_t(4) << 20;     // the JSON chunk (tinygltf's model costs ~30x its JSON in memory)
  int max_json_depth = 64;                     // nesting of arrays/objects anywhere in the JSON (extras included)
  size_t max_vertices = 4'000'000;             // per scene: POSITION counts summed over every mesh instance
  size_t max_triangles = 4'000'000;            // per scene, over every mesh instance
  int max_image_side_px = kMaxImageSize;       // 8192: each side of each image, read from its header before decoding
  size_t max_image_pixels = size_t(64) << 20;  // 64 Mpx: summed over every image of the file, before decoding
  // Texture bytes the decoded Scene holds (RGB pixels + encoded copy), counted per mesh instance that uses them.
  size_t max_scene_texture_bytes = size_t(512) << 20;
  size_t max_meshopt_bytes = size_t(128) << 20;  // EXT_meshopt_compression output, summed over the file
  size_t max_draco_bytes = size_t(128) << 20;    // KHR_draco_mesh_compression output, summed over the file
};

// Decodes GLB bytes from an untrusted source: any GLB rgbdcast writes and ordinary textured-mesh GLBs. Textures are
// decoded to Mesh::texture (RGB8). A truncated or malformed file is an kInvalidInput error, never a crash.
// A GLB must be self-contained: a buffer or image with a `uri` is rejected ("external URI not allowed", or "data URI
// not allowed"), the filesystem is never touched, and only one buffer (the BIN chunk) may exist. Every accessor needs
// a bufferView that holds count x stride bytes. Going past `limits` is kInvalidInput naming the limit.
// Error messages never carry paths or URIs. Thread-safe (no shared state).
// One SceneNode per mesh primitive (triangles -> mesh, points -> points). Positions are floats: quantized positions
// are dequantized with their node's translation + scale (so an rgbdcast file gives back metres and its to_world);
// UVs have KHR_texture_transform applied (0..1 over the texture, origin top-left).
Result<Scene> decode_glb(const std::uint8_t* data, size_t size, const GlbDecodeLimits& limits = {});
// A trusted local file (the CLI): same checks; errors are prefixed with the path.
Result<Scene> read_glb_file(const std::string& path, const GlbDecodeLimits& limits = {});

// Re-encodes GLB bytes from an untrusted source in the flavour options.flavor: decode_glb, then encode_glb. Geometry,
// cameras (with their exact intrinsics), node placement and scene extras carry over; a JPEG texture is copied
// byte for byte, a PNG one is re-encoded as JPEG (options.jpeg_quality) for compat. Errors are decode_glb's
// (kInvalidInput, kEmpty) or encode_glb's.
Result<std::vector<std::uint8_t>> convert_glb(const std::uint8_t* data, size_t size, const GlbWriteOptions& options,
                                              GlbStats* stats = nullptr);

}  // namespace rgbdcast
