#pragma once
// Several GLBs merged into one without decoding them: each part's JSON document is rebased into one document (its
// buffers, bufferViews, accessors, images, samplers, textures, materials, meshes, nodes and cameras appended after the
// previous parts'; its scene's root nodes become roots of the merged scene; extensionsUsed and extensionsRequired are
// united), and the parts' BIN chunks are laid end to end, each padded to 4 bytes, as the merged BIN chunk. The bytes
// of the BIN chunks are never parsed, so compressed data (EXT_meshopt_compression, KHR_draco_mesh_compression,
// JPEG/PNG images) passes through as it is, and a merge streams: only the JSON chunks are held in memory.
//
// Buffers: a part's buffer 0 without a uri is its BIN chunk and becomes a range of the merged buffer 0; a buffer
// without a uri that is an EXT_meshopt_compression fallback (no data) becomes a range of one merged fallback buffer.
// A part with any other buffer (a uri, or a second BIN-less buffer that is no fallback), or with skins, animations or
// document-level extensions (which hold indices this merge does not rebase), is refused (kInvalidInput), as is a
// JSON chunk that does not parse or an index out of range. Parts are trusted to be valid glTF otherwise: the merge
// rewrites indices and offsets, it does not validate (the service merges its own tile files).
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "scene/result.h"

namespace rgbdcast::glb {

// A GLB's JSON chunk and where its BIN chunk lies in the file (bin_length 0: no BIN chunk).
struct GlbLayout {
  std::string json;
  std::uint64_t bin_offset = 0, bin_length = 0;
};

// Reads the 12-byte header and the JSON chunk of the GLB in an open file of `file_size` bytes (pread: the file
// position is not used). Every length is checked against the file size; a JSON chunk over max_json_bytes is refused.
// kInvalidInput for a malformed file, kIo for a failed read.
Result<GlbLayout> read_glb_layout(int fd, std::uint64_t file_size, std::uint64_t max_json_bytes = 64u << 20);

// The merged GLB of parts (their JSON and BIN chunk lengths, in order): its first bytes (the GLB header, the JSON
// chunk and the BIN chunk's header) and where each part's BIN chunk goes. The output is head, then for each part its
// BIN bytes followed by bin_padding[i] zero bytes; total_bytes in all.
struct GlbMergePlan {
  std::string head;
  std::vector<std::uint64_t> bin_padding;
  std::uint64_t total_bytes = 0;
};
Result<GlbMergePlan> plan_glb_merge(const std::vector<GlbLayout>& parts);

// The merge in memory (tests, small inputs): GLB bytes in, GLB bytes out.
Result<std::vector<std::uint8_t>> merge_glbs(const std::vector<std::vector<std::uint8_t>>& glbs);

// The merge of GLB files, read on demand. open() opens every file and reads its JSON chunk; the files stay open until
// the object is destroyed, so a file removed (unlinked) meanwhile is still read whole. read() copies any range of
// the merged bytes. Not thread-safe (one reader at a time); reads use pread, so the object may move between threads.
class GlbFileMerge {
 public:
  // kNotFound naming the file that does not exist, kInvalidInput for one that is no mergeable GLB, kIo otherwise.
  static Result<std::unique_ptr<GlbFileMerge>> open(const std::vector<std::string>& paths);
  ~GlbFileMerge();
  GlbFileMerge(const GlbFileMerge&) = delete;
  GlbFileMerge& operator=(const GlbFileMerge&) = delete;

  std::uint64_t size() const { return plan_.total_bytes; }
  size_t parts() const { return parts_.size(); }
  // Copies bytes [offset, offset + n) of the merged GLB to out; false when the range passes the end or a file read
  // comes up short (a file that was truncated in place).
  bool read(std::uint64_t offset, char* out, size_t n) const;

 private:
  GlbFileMerge() = default;
  struct Part {
    int fd = -1;
    std::uint64_t bin_offset = 0, bin_length = 0, padding = 0;
    std::uint64_t starts_at = 0;  // in the merged bytes
  };
  GlbMergePlan plan_;
  std::vector<Part> parts_;
};

}  // namespace rgbdcast::glb
