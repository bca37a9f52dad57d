#include "gltf/glb_merge.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include <nlohmann/json.hpp>

#include "gltf/glb_container.h"

namespace rgbdcast::glb {
namespace {

using nlohmann::json;

constexpr std::uint32_t kMagic = 0x46546C67;      // "glTF"
constexpr std::uint32_t kChunkJson = 0x4E4F534A;  // "JSON"
constexpr std::uint32_t kChunkBin = 0x004E4942;   // "BIN\0"

Error bad(const std::string& what) { return make_error(ErrorCode::kInvalidInput, "GLB merge: " + what); }
std::uint64_t pad4(std::uint64_t n) { return (4 - n % 4) % 4; }

std::uint32_t read_u32(const unsigned char* p) {
  return std::uint32_t(p[0]) | (std::uint32_t(p[1]) << 8) | (std::uint32_t(p[2]) << 16) | (std::uint32_t(p[3]) << 24);
}
void put_u32(std::string& out, std::uint64_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}

// What one part adds to each array of the merged document: the merged arrays' sizes before it (the offsets its
// indices move by) and its own sizes (the bounds its indices are checked against).
struct Span {
  size_t base = 0, count = 0;
};

// The merged document being built.
struct MergedDocument {
  json arrays = json::object();  // "bufferViews", "accessors", ... -> array
  json roots = json::array();
  std::vector<std::string> used, required;
  std::uint64_t bin_length = 0, fallback_length = 0;
};

// Where one part's entries of each array go in the merged document.
struct PartSpans {
  Span views, accessors, images, samplers, textures, materials, meshes, nodes, cameras;
  PartSpans(const json& part, MergedDocument& doc) {
    auto span = [&](const char* key) {
      if (!doc.arrays.contains(key)) doc.arrays[key] = json::array();
      const size_t count = part.contains(key) && part[key].is_array() ? part[key].size() : 0;
      return Span{doc.arrays[key].size(), count};
    };
    views = span("bufferViews"), accessors = span("accessors"), images = span("images");
    samplers = span("samplers"), textures = span("textures"), materials = span("materials");
    meshes = span("meshes"), nodes = span("nodes"), cameras = span("cameras");
  }
};

// Moves an index by span.base, after checking it is below span.count.
bool rebase_index(json& v, const Span& span) {
  if (!v.is_number_integer()) return false;
  const std::int64_t i = v.get<std::int64_t>();
  if (i < 0 || static_cast<std::uint64_t>(i) >= span.count) return false;
  v = static_cast<std::uint64_t>(span.base + static_cast<size_t>(i));
  return true;
}

// The index at j[key], when present.
bool rebase(json& j, const char* key, const Span& span) {
  return !j.is_object() || !j.contains(key) || rebase_index(j[key], span);
}

// Every value of an array or object.
bool rebase_each(json& values, const Span& span) {
  if (!values.is_array() && !values.is_object()) return false;
  for (auto& v : values)
    if (!rebase_index(v, span)) return false;
  return true;
}

// Every texture reference in a material, at any depth (core and extension texture infos): an object under a key
// ending in "Texture" holds the texture's "index".
bool rebase_texture_infos(json& j, const Span& textures) {
  if (j.is_array()) {
    for (auto& e : j)
      if (!rebase_texture_infos(e, textures)) return false;
    return true;
  }
  if (!j.is_object()) return true;
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string& key = it.key();
    const bool is_info = key.size() > 7 && key.compare(key.size() - 7, 7, "Texture") == 0 && it->is_object();
    if (is_info && !rebase(*it, "index", textures)) return false;
    if (!rebase_texture_infos(*it, textures)) return false;
  }
  return true;
}

bool is_meshopt_fallback(const json& buffer) {
  return buffer.contains("extensions") && buffer["extensions"].contains("EXT_meshopt_compression") &&
         buffer["extensions"]["EXT_meshopt_compression"].value("fallback", false);
}

// Where a part's buffer lands: merged buffer 0 (the BIN chunk) or 1 (the meshopt fallback), at an offset.
struct BufferPlace {
  int buffer = 0;
  std::uint64_t offset = 0;
};

Result<std::vector<BufferPlace>> place_buffers(const json& part, std::uint64_t bin_length, MergedDocument& doc) {
  std::vector<BufferPlace> places;
  for (const auto& b : part.value("buffers", json::array())) {
    const std::uint64_t length = b.value("byteLength", std::uint64_t(0));
    if (b.contains("uri")) return bad("a buffer with a uri (only GLB-stored buffers merge)");
    if (is_meshopt_fallback(b)) {
      places.push_back({1, doc.fallback_length});
      doc.fallback_length += length + pad4(length);
    } else if (places.empty()) {
      if (length > bin_length) return bad("buffer 0 is longer than the BIN chunk");
      places.push_back({0, doc.bin_length});
    } else {
      return bad("a second buffer without a uri that is no EXT_meshopt_compression fallback");
    }
  }
  doc.bin_length += bin_length + pad4(bin_length);
  return places;
}

bool move_to_buffer(json& j, const std::vector<BufferPlace>& places) {
  if (!j.contains("buffer") || !j["buffer"].is_number_integer()) return false;
  const std::int64_t b = j["buffer"].get<std::int64_t>();
  if (b < 0 || static_cast<size_t>(b) >= places.size()) return false;
  j["buffer"] = places[static_cast<size_t>(b)].buffer;
  j["byteOffset"] = j.value("byteOffset", std::uint64_t(0)) + places[static_cast<size_t>(b)].offset;
  return true;
}

Status append_views_and_accessors(json& part, const PartSpans& at, const std::vector<BufferPlace>& places,
                                  MergedDocument& doc) {
  const Span& views = at.views;
  for (auto& v : part.value("bufferViews", json::array())) {
    if (!move_to_buffer(v, places)) return bad("a bufferView's buffer is out of range");
    if (v.contains("extensions") && v["extensions"].contains("EXT_meshopt_compression") &&
        !move_to_buffer(v["extensions"]["EXT_meshopt_compression"], places))
      return bad("an EXT_meshopt_compression buffer is out of range");
    doc.arrays["bufferViews"].push_back(std::move(v));
  }
  for (auto& a : part.value("accessors", json::array())) {
    bool ok = rebase(a, "bufferView", views);
    if (a.contains("sparse"))
      ok = ok && rebase(a["sparse"]["indices"], "bufferView", views) &&
           rebase(a["sparse"]["values"], "bufferView", views);
    if (!ok) return bad("an accessor's bufferView is out of range");
    doc.arrays["accessors"].push_back(std::move(a));
  }
  return ok_status();
}

Status append_images_and_materials(json& part, const PartSpans& at, MergedDocument& doc) {
  const Span &views = at.views, &images = at.images, &samplers = at.samplers, &textures = at.textures;
  for (auto& i : part.value("images", json::array())) {
    if (i.contains("uri") && (!i["uri"].is_string() || i["uri"].get<std::string>().rfind("data:", 0) != 0))
      return bad("an image with an external uri");
    if (!rebase(i, "bufferView", views)) return bad("an image's bufferView is out of range");
    doc.arrays["images"].push_back(std::move(i));
  }
  for (auto& s : part.value("samplers", json::array())) doc.arrays["samplers"].push_back(std::move(s));
  for (auto& t : part.value("textures", json::array())) {
    bool ok = rebase(t, "sampler", samplers) && rebase(t, "source", images);
    if (t.contains("extensions") && t["extensions"].is_object())  // EXT_texture_webp, KHR_texture_basisu, ...
      for (auto& e : t["extensions"]) ok = ok && rebase(e, "source", images);
    if (!ok) return bad("a texture's source or sampler is out of range");
    doc.arrays["textures"].push_back(std::move(t));
  }
  for (auto& m : part.value("materials", json::array())) {
    if (!rebase_texture_infos(m, textures)) return bad("a material's texture is out of range");
    doc.arrays["materials"].push_back(std::move(m));
  }
  return ok_status();
}

Status append_meshes(json& part, const PartSpans& at, MergedDocument& doc) {
  const Span &accessors = at.accessors, &views = at.views, &materials = at.materials;
  for (auto& mesh : part.value("meshes", json::array())) {
    if (!mesh.contains("primitives") || !mesh["primitives"].is_array()) return bad("a mesh without primitives");
    for (auto& p : mesh["primitives"]) {
      bool ok = rebase(p, "indices", accessors) && rebase(p, "material", materials);
      if (p.contains("attributes") && p["attributes"].is_object()) ok = ok && rebase_each(p["attributes"], accessors);
      if (p.contains("targets") && p["targets"].is_array())
        for (auto& target : p["targets"]) ok = ok && rebase_each(target, accessors);
      if (p.contains("extensions") && p["extensions"].contains("KHR_draco_mesh_compression"))
        ok = ok && rebase(p["extensions"]["KHR_draco_mesh_compression"], "bufferView", views);
      if (!ok) return bad("a primitive's accessor, material or bufferView is out of range");
    }
    doc.arrays["meshes"].push_back(std::move(mesh));
  }
  return ok_status();
}

Status append_nodes(json& part, const PartSpans& at, MergedDocument& doc) {
  const Span &nodes = at.nodes, &cameras = at.cameras, &meshes = at.meshes;
  for (auto& c : part.value("cameras", json::array())) doc.arrays["cameras"].push_back(std::move(c));
  std::vector<bool> is_child(nodes.count, false);
  for (auto& n : part.value("nodes", json::array())) {
    if (n.contains("skin")) return bad("a skinned node (skins do not merge)");
    bool ok = rebase(n, "mesh", meshes) && rebase(n, "camera", cameras);
    if (n.contains("children")) {
      for (const auto& c : n["children"])
        if (c.is_number_integer() && c.get<std::int64_t>() >= 0 && c.get<std::uint64_t>() < nodes.count)
          is_child[c.get<size_t>()] = true;
      ok = ok && rebase_each(n["children"], nodes);
    }
    if (!ok) return bad("a node's mesh, camera or child is out of range");
    doc.arrays["nodes"].push_back(std::move(n));
  }
  // The part's scene (its "scene", else the first) gives the roots; a part without scenes: every node no one holds.
  json roots = json::array();
  const auto& scenes = part.value("scenes", json::array());
  if (!scenes.empty()) {
    const size_t s = part.value("scene", size_t(0));
    if (s >= scenes.size()) return bad("the default scene is out of range");
    roots = scenes[s].value("nodes", json::array());
    if (!rebase_each(roots, nodes)) return bad("a scene's node is out of range");
  } else {
    for (size_t i = 0; i < nodes.count; ++i)
      if (!is_child[i]) roots.push_back(nodes.base + i);
  }
  for (auto& r : roots) doc.roots.push_back(r);
  return ok_status();
}

void unite(std::vector<std::string>& into, const json& names) {
  if (!names.is_array()) return;
  for (const auto& n : names)
    if (n.is_string() && std::find(into.begin(), into.end(), n.get<std::string>()) == into.end())
      into.push_back(n.get<std::string>());
}

Status append_part(const GlbLayout& layout, MergedDocument& doc) {
  json part = json::parse(layout.json, nullptr, false);
  if (part.is_discarded() || !part.is_object()) return bad("a JSON chunk that does not parse");
  for (const char* key : {"skins", "animations"})
    if (part.contains(key) && !part[key].empty())
      return bad(std::string("a part with ") + key + " (they do not merge)");
  if (part.contains("extensions") && !part["extensions"].empty())
    return bad("a part with document-level extensions (they do not merge)");
  const PartSpans at(part, doc);
  auto places = place_buffers(part, layout.bin_length, doc);
  if (!places) return places.error();
  if (auto st = append_views_and_accessors(part, at, *places, doc); !st) return st;
  if (auto st = append_images_and_materials(part, at, doc); !st) return st;
  if (auto st = append_meshes(part, at, doc); !st) return st;
  if (auto st = append_nodes(part, at, doc); !st) return st;
  unite(doc.used, part.value("extensionsUsed", json::array()));
  unite(doc.required, part.value("extensionsRequired", json::array()));
  return ok_status();
}

std::string merged_json(MergedDocument& doc) {
  json out = {{"asset", {{"version", "2.0"}, {"generator", "rgbdcast"}}}};
  json buffers = json::array();
  if (doc.bin_length > 0) buffers.push_back({{"byteLength", doc.bin_length}});
  if (doc.fallback_length > 0) {
    if (buffers.empty()) buffers.push_back({{"byteLength", 0}});  // keeps the fallback at index 1, as placed
    buffers.push_back(
        {{"byteLength", doc.fallback_length}, {"extensions", {{"EXT_meshopt_compression", {{"fallback", true}}}}}});
  }
  if (!buffers.empty()) out["buffers"] = std::move(buffers);
  for (auto it = doc.arrays.begin(); it != doc.arrays.end(); ++it)
    if (!it->empty()) out[it.key()] = std::move(*it);
  out["scenes"] = json::array({{{"nodes", doc.roots}}});
  out["scene"] = 0;
  if (!doc.used.empty()) out["extensionsUsed"] = doc.used;
  if (!doc.required.empty()) out["extensionsRequired"] = doc.required;
  return out.dump(-1, ' ', false, json::error_handler_t::replace);
}

}  // namespace

Result<GlbLayout> read_glb_layout(int fd, std::uint64_t file_size, std::uint64_t max_json_bytes) {
  auto read_at = [&](std::uint64_t at, void* out, size_t n) -> Status {
    size_t done = 0;
    while (done < n) {
      const ssize_t got = ::pread(fd, static_cast<char*>(out) + done, n - done, static_cast<off_t>(at + done));
      if (got < 0 && errno == EINTR) continue;
      if (got < 0) return make_error(ErrorCode::kIo, std::string("GLB read failed: ") + std::strerror(errno));
      if (got == 0) return bad("the file ends early");
      done += static_cast<size_t>(got);
    }
    return ok_status();
  };
  unsigned char header[20];
  if (file_size < 20) return bad("shorter than a GLB header and its JSON chunk header");
  if (auto st = read_at(0, header, 20); !st) return st.error();
  if (read_u32(header) != kMagic || read_u32(header + 4) != 2) return bad("not a glTF 2.0 GLB");
  const std::uint64_t length = std::min<std::uint64_t>(read_u32(header + 8), file_size);
  const std::uint64_t json_length = read_u32(header + 12);
  if (read_u32(header + 16) != kChunkJson) return bad("the first chunk is not JSON");
  if (json_length > max_json_bytes || json_length > length - 20) return bad("the JSON chunk is too long");
  GlbLayout out;
  out.json.resize(json_length);
  if (auto st = read_at(20, out.json.data(), json_length); !st) return st.error();
  const std::uint64_t next = 20 + json_length + pad4(json_length);
  if (next + 8 <= length) {
    unsigned char chunk[8];
    if (auto st = read_at(next, chunk, 8); !st) return st.error();
    if (read_u32(chunk + 4) == kChunkBin) {
      out.bin_offset = next + 8;
      out.bin_length = read_u32(chunk);
      if (out.bin_length > length - out.bin_offset) return bad("the BIN chunk runs past the end of the file");
    }
  }
  return out;
}

Result<GlbMergePlan> plan_glb_merge(const std::vector<GlbLayout>& parts) {
  if (parts.empty()) return make_error(ErrorCode::kInvalidArgument, "GLB merge: nothing to merge");
  MergedDocument doc;
  GlbMergePlan plan;
  for (size_t i = 0; i < parts.size(); ++i) {
    if (auto st = append_part(parts[i], doc); !st)
      return make_error(st.error().code, st.error().message + " (part " + std::to_string(i) + ")");
    plan.bin_padding.push_back(pad4(parts[i].bin_length));
  }
  std::string json_text = merged_json(doc);
  json_text.append(pad4(json_text.size()), ' ');
  const std::uint64_t bin = doc.bin_length;
  plan.total_bytes = 12 + 8 + json_text.size() + (bin > 0 ? 8 + bin : 0);
  if (plan.total_bytes > 0xffffffffull) return make_error(ErrorCode::kInvalidArgument, "GLB merge: over 4 GiB");
  plan.head.reserve(28 + json_text.size());
  put_u32(plan.head, kMagic);
  put_u32(plan.head, 2);
  put_u32(plan.head, plan.total_bytes);
  put_u32(plan.head, json_text.size());
  put_u32(plan.head, kChunkJson);
  plan.head += json_text;
  if (bin > 0) {
    put_u32(plan.head, bin);
    put_u32(plan.head, kChunkBin);
  }
  return plan;
}

Result<std::vector<std::uint8_t>> merge_glbs(const std::vector<std::vector<std::uint8_t>>& glbs) {
  std::vector<GlbChunks> chunks;
  std::vector<GlbLayout> layouts;
  for (const auto& g : glbs) {
    auto c = parse_glb(g.data(), g.size());
    if (!c) return c.error();
    layouts.push_back({c->json, 0, c->bin.size()});
    chunks.push_back(std::move(*c));
  }
  auto plan = plan_glb_merge(layouts);
  if (!plan) return plan.error();
  std::vector<std::uint8_t> out(plan->head.begin(), plan->head.end());
  out.reserve(plan->total_bytes);
  for (size_t i = 0; i < chunks.size(); ++i) {
    out.insert(out.end(), chunks[i].bin.begin(), chunks[i].bin.end());
    out.insert(out.end(), plan->bin_padding[i], 0);
  }
  return out;
}

Result<std::unique_ptr<GlbFileMerge>> GlbFileMerge::open(const std::vector<std::string>& paths) {
  std::unique_ptr<GlbFileMerge> merge(new GlbFileMerge());
  std::vector<GlbLayout> layouts;
  for (const auto& path : paths) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
      const std::string name = path.substr(path.find_last_of('/') + 1);
      return make_error(errno == ENOENT ? ErrorCode::kNotFound : ErrorCode::kIo,
                        "GLB merge: cannot open " + name + ": " + std::strerror(errno));
    }
    merge->parts_.push_back({fd});
    struct stat st {};
    if (::fstat(fd, &st) != 0) return make_error(ErrorCode::kIo, "GLB merge: fstat failed");
    auto layout = read_glb_layout(fd, static_cast<std::uint64_t>(st.st_size));
    if (!layout) return layout.error();
    merge->parts_.back().bin_offset = layout->bin_offset;
    merge->parts_.back().bin_length = layout->bin_length;
    layouts.push_back(std::move(*layout));
  }
  auto plan = plan_glb_merge(layouts);
  if (!plan) return plan.error();
  merge->plan_ = std::move(*plan);
  std::uint64_t at = merge->plan_.head.size();
  for (size_t i = 0; i < merge->parts_.size(); ++i) {
    merge->parts_[i].padding = merge->plan_.bin_padding[i];
    merge->parts_[i].starts_at = at;
    at += merge->parts_[i].bin_length + merge->parts_[i].padding;
  }
  return merge;
}

GlbFileMerge::~GlbFileMerge() {
  for (const auto& p : parts_) ::close(p.fd);
}

bool GlbFileMerge::read(std::uint64_t offset, char* out, size_t n) const {
  if (offset > plan_.total_bytes || n > plan_.total_bytes - offset) return false;
  while (n > 0) {
    if (offset < plan_.head.size()) {
      const size_t k = std::min<std::uint64_t>(n, plan_.head.size() - offset);
      std::memcpy(out, plan_.head.data() + offset, k);
      offset += k, out += k, n -= k;
      continue;
    }
    // The last part starting at or before offset.
    auto it = std::upper_bound(parts_.begin(), parts_.end(), offset,
                               [](std::uint64_t o, const Part& p) { return o < p.starts_at; });
    const Part& p = *std::prev(it);
    const std::uint64_t within = offset - p.starts_at;
    size_t k = 0;
    if (within < p.bin_length) {
      k = std::min<std::uint64_t>(n, p.bin_length - within);
      const ssize_t got = ::pread(p.fd, out, k, static_cast<off_t>(p.bin_offset + within));
      if (got < 0 && errno == EINTR) continue;
      if (got <= 0) return false;
      k = static_cast<size_t>(got);
    } else {
      k = std::min<std::uint64_t>(n, p.bin_length + p.padding - within);
      std::memset(out, 0, k);
    }
    offset += k, out += k, n -= k;
  }
  return true;
}

}  // namespace rgbdcast::glb
