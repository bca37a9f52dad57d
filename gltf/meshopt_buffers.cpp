#include "gltf/meshopt_buffers.h"

#include <meshoptimizer.h>

#include <map>
#include <nlohmann/json.hpp>

#include "gltf/pass_helpers.h"

namespace rgbdcast::glb {
namespace {

using nlohmann::json;
constexpr const char* kExt = "EXT_meshopt_compression";

Error bad(const std::string& what) { return make_error(ErrorCode::kInvalidInput, "GLB meshopt: " + what); }

struct ViewUse {
  std::string mode;  // ATTRIBUTES, TRIANGLES, INDICES
  size_t count = 0, stride = 0;
};

}  // namespace

Result<GlbChunks> meshopt_compress(const GlbChunks& in) {
  try {
    json doc = json::parse(in.json);
    std::map<size_t, ViewUse> uses;
    auto& accessors = doc.at("accessors");
    auto& views = doc.at("bufferViews");
    for (const auto& mesh : doc.value("meshes", json::array()))
      for (const auto& prim : mesh.at("primitives")) {
        for (const auto& [name, acc_index] : prim.at("attributes").items()) {
          const auto& acc = accessors.at(acc_index.get<size_t>());
          const size_t v = acc.at("bufferView").get<size_t>();
          const size_t stride = views.at(v).value("byteStride", 0);
          if (stride == 0 || stride % 4 != 0) return bad("attribute " + name + " has no byteStride multiple of 4");
          uses[v] = {"ATTRIBUTES", acc.at("count").get<size_t>(), stride};
        }
        if (prim.contains("indices")) {
          const auto& acc = accessors.at(prim.at("indices").get<size_t>());
          const size_t v = acc.at("bufferView").get<size_t>();
          const size_t count = acc.at("count").get<size_t>();
          const size_t stride = component_size(acc.at("componentType").get<int>());
          const bool triangles = prim.value("mode", 4) == 4 && count % 3 == 0 && stride >= 2;
          uses[v] = {triangles ? "TRIANGLES" : "INDICES", count, stride};
        }
      }
    GlbChunks out;
    out.has_bin = true;
    size_t fallback_size = 0;
    for (size_t v = 0; v < views.size(); ++v) {
      json& view = views[v];
      if (view.value("buffer", 0) != 0) return bad("only single-buffer GLBs are compressed");
      const size_t off = view.value("byteOffset", size_t(0)), len = view.at("byteLength").get<size_t>();
      if (off > in.bin.size() || len > in.bin.size() - off) return bad("bufferView past the BIN chunk");
      const std::uint8_t* src = in.bin.data() + off;
      align4(out.bin);
      auto it = uses.find(v);
      if (it == uses.end() || (it->second.mode == "INDICES" && it->second.stride == 1)) {
        view["byteOffset"] = out.bin.size();
        out.bin.insert(out.bin.end(), src, src + len);
        continue;
      }
      const ViewUse& u = it->second;
      if (u.count * u.stride != len) return bad("bufferView " + std::to_string(v) + " size is not count x stride");
      std::vector<std::uint8_t> enc;
      if (u.mode == "ATTRIBUTES") {
        enc.resize(meshopt_encodeVertexBufferBound(u.count, u.stride));
        enc.resize(meshopt_encodeVertexBuffer(enc.data(), enc.size(), src, u.count, u.stride));
      } else {
        std::vector<std::uint32_t> idx(u.count);
        for (size_t i = 0; i < u.count; ++i)
          idx[i] = u.stride == 2 ? (src[2 * i] | (src[2 * i + 1] << 8))
                                 : (src[4 * i] | (src[4 * i + 1] << 8) | (src[4 * i + 2] << 16) |
                                    (std::uint32_t(src[4 * i + 3]) << 24));
        size_t max_index = 0;
        for (auto i : idx) max_index = std::max<size_t>(max_index, i);
        if (u.mode == "TRIANGLES") {
          enc.resize(meshopt_encodeIndexBufferBound(u.count, max_index + 1));
          enc.resize(meshopt_encodeIndexBuffer(enc.data(), enc.size(), idx.data(), u.count));
        } else {
          enc.resize(meshopt_encodeIndexSequenceBound(u.count, max_index + 1));
          enc.resize(meshopt_encodeIndexSequence(enc.data(), enc.size(), idx.data(), u.count));
        }
      }
      if (enc.empty()) return make_error(ErrorCode::kInternal, "meshopt encoding failed");
      json ext = {{"buffer", 0},
                  {"byteOffset", out.bin.size()},
                  {"byteLength", enc.size()},
                  {"byteStride", u.stride},
                  {"count", u.count},
                  {"mode", u.mode}};
      out.bin.insert(out.bin.end(), enc.begin(), enc.end());
      fallback_size = (fallback_size + 3) & ~size_t(3);
      view["buffer"] = 1;
      view["byteOffset"] = fallback_size;
      view["extensions"][kExt] = ext;
      fallback_size += len;
    }
    align4(out.bin);
    doc["buffers"] =
        json::array({json{{"byteLength", out.bin.size()}}, json{{"byteLength", std::max<size_t>(fallback_size, 4)},
                                                                {"extensions", {{kExt, {{"fallback", true}}}}}}});
    require_extension(doc, kExt);
    out.json = doc.dump();
    return out;
  } catch (const json::exception& e) {
    return make_error(ErrorCode::kInternal, std::string("meshopt compress: ") + e.what());
  }
}

bool uses_meshopt(const GlbChunks& in) { return in.json.find(kExt) != std::string::npos; }

Result<GlbChunks> meshopt_decompress(const GlbChunks& in, size_t max_decoded_bytes) {
  if (!uses_meshopt(in)) return in;
  try {
    json doc = json::parse(in.json);
    if (!doc.is_object()) return bad("JSON is not an object");
    if (!lists_extension(doc, "extensionsUsed", kExt)) return in;
    GlbChunks out = in;
    out.has_bin = true;
    json& buffers = doc.at("buffers");
    json& views = doc.at("bufferViews");
    if (!buffers.is_array() || !views.is_array() || buffers.empty()) return bad("buffers/bufferViews are not arrays");
    if (buffers[0].contains("uri")) return bad("buffer 0 must be the BIN chunk");
    if (buffers[0].at("byteLength").get<size_t>() > in.bin.size())
      return bad("buffer 0 is longer than the BIN chunk (truncated file)");
    size_t decoded_total = 0;
    for (size_t v = 0; v < views.size(); ++v) {
      json& view = views[v];
      if (!view.is_object() || !view.contains("extensions") || !view["extensions"].contains(kExt)) continue;
      const json& ext = view["extensions"][kExt];
      const size_t buf = ext.at("buffer").get<size_t>();
      if (buf != 0 || (buffers.at(0).contains("uri")))
        return bad("bufferView " + std::to_string(v) + ": compressed data must be in the BIN chunk");
      const size_t off = ext.value("byteOffset", size_t(0)), len = ext.at("byteLength").get<size_t>();
      const size_t count = ext.at("count").get<size_t>(), stride = ext.at("byteStride").get<size_t>();
      const std::string mode = ext.at("mode").get<std::string>();
      const std::string filter = ext.value("filter", std::string("NONE"));
      if (off > in.bin.size() || len > in.bin.size() - off) return bad("compressed data past the BIN chunk");
      if (stride == 0 || stride > 256) return bad("absurd byteStride " + std::to_string(stride));
      // The output is bounded by what the file declares (count x byteStride must fit the bufferView, which must fit
      // its fallback buffer's byteLength) and by the budget, before anything is allocated.
      if (count > (max_decoded_bytes - decoded_total) / stride)
        return bad("decoded data over the limit of " + std::to_string(max_decoded_bytes) + " bytes");
      const size_t size = count * stride;
      decoded_total += size;
      const size_t view_off = view.value("byteOffset", size_t(0)), view_len = view.at("byteLength").get<size_t>();
      if (view_len < size) return bad("bufferView shorter than count x byteStride");
      const size_t target = view.value("buffer", size_t(0));
      if (target >= buffers.size() || !buffers[target].is_object()) return bad("bufferView buffer index out of range");
      const size_t declared = buffers[target].at("byteLength").get<size_t>();
      if (view_off > declared || view_len > declared - view_off) return bad("bufferView past its buffer's byteLength");
      align4(out.bin);
      const size_t at = out.bin.size();
      out.bin.resize(at + size);  // decoded in place: no second copy
      std::uint8_t* dec = out.bin.data() + at;
      const std::uint8_t* src = in.bin.data() + off;
      int rc = -1;
      if (mode == "ATTRIBUTES") {
        if (stride % 4 != 0) return bad("ATTRIBUTES byteStride must be a multiple of 4");
        rc = meshopt_decodeVertexBuffer(dec, count, stride, src, len);
        if (rc == 0 && filter == "OCTAHEDRAL" && (stride == 4 || stride == 8))
          meshopt_decodeFilterOct(dec, count, stride);
        else if (rc == 0 && filter == "QUATERNION" && stride == 8)
          meshopt_decodeFilterQuat(dec, count, stride);
        else if (rc == 0 && filter == "EXPONENTIAL")
          meshopt_decodeFilterExp(dec, count, stride);
        else if (rc == 0 && filter != "NONE")
          return bad("unsupported filter " + filter + " with byteStride " + std::to_string(stride));
      } else if (mode == "TRIANGLES" || mode == "INDICES") {
        if (stride != 2 && stride != 4) return bad("index byteStride must be 2 or 4");
        if (mode == "TRIANGLES" && count % 3 != 0) return bad("TRIANGLES count is not a multiple of 3");
        rc = mode == "TRIANGLES" ? meshopt_decodeIndexBuffer(dec, count, stride, src, len)
                                 : meshopt_decodeIndexSequence(dec, count, stride, src, len);
      } else {
        return bad("unknown mode " + mode);
      }
      if (rc != 0) return bad("bufferView " + std::to_string(v) + " does not decode (corrupt data)");
      view["buffer"] = 0;
      view["byteOffset"] = at;
      view["byteLength"] = size;
      view["extensions"].erase(kExt);
      if (view["extensions"].empty()) view.erase("extensions");
    }
    // Drop the fallback buffers; no view may still point into one.
    std::vector<long> remap(buffers.size(), -1);
    json kept = json::array();
    for (size_t b = 0; b < buffers.size(); ++b) {
      const json& buffer = buffers[b];
      const bool fallback = buffer.is_object() && buffer.contains("extensions") &&
                            buffer["extensions"].contains(kExt) && buffer["extensions"][kExt].value("fallback", false);
      if (fallback) continue;
      remap[b] = static_cast<long>(kept.size());
      kept.push_back(buffer);
    }
    if (kept.empty() || remap[0] != 0) return bad("buffer 0 must be the BIN chunk");
    for (size_t v = 0; v < views.size(); ++v) {
      const size_t b = views[v].value("buffer", size_t(0));
      if (b >= remap.size() || remap[b] < 0)
        return bad("bufferView " + std::to_string(v) + " points into a fallback buffer without data");
      views[v]["buffer"] = remap[b];
    }
    align4(out.bin);
    kept[0]["byteLength"] = out.bin.size();
    doc["buffers"] = kept;
    drop_extension(doc, kExt);
    out.json = doc.dump();
    return out;
  } catch (const json::exception& e) {
    return bad(std::string("malformed JSON: ") + e.what());
  }
}

}  // namespace rgbdcast::glb
