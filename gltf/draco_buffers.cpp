#include "gltf/draco_buffers.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string_view>

#include "gltf/draco_codec.h"
#include "gltf/draco_header.h"
#include "gltf/pass_helpers.h"
#include "scene/image_probe.h"

namespace rgbdcast::glb {
namespace {

using nlohmann::json;
constexpr const char* kExt = "KHR_draco_mesh_compression";

Error bad(const std::string& what) { return make_error(ErrorCode::kInvalidInput, "GLB draco: " + what); }
Error cannot(const std::string& what) { return make_error(ErrorCode::kInvalidArgument, "draco compress: " + what); }

size_t index_of(const json& j) {
  if (!j.is_number_unsigned()) throw std::out_of_range("index is not an unsigned integer");
  return j.get<size_t>();
}

// Bits for a float attribute of largest per-axis range `range` so that Draco's step range / (2^bits - 1) is at
// most `step`.
int bits_for(double range, double step) {
  if (!(range > 0) || !(step > 0)) return 1;
  const double levels = range / step + 1.0;
  return std::clamp(static_cast<int>(std::ceil(std::log2(levels) - 1e-9)), 1, 30);
}

// The larger side in texels of the baseColorTexture that samples TEXCOORD_<set> of `prim`; 0 when none does.
int texture_side_for(const json& doc, const json& prim, int set, const std::vector<std::uint8_t>& bin) {
  try {
    if (!prim.contains("material")) return 0;
    const json& tex =
        doc.at("materials").at(index_of(prim["material"])).at("pbrMetallicRoughness").at("baseColorTexture");
    if (tex.value("texCoord", 0) != set) return 0;
    const json& image = doc.at("images").at(index_of(doc.at("textures").at(index_of(tex.at("index"))).at("source")));
    const json& view = doc.at("bufferViews").at(index_of(image.at("bufferView")));
    const size_t off = view.value("byteOffset", size_t(0)), len = view.at("byteLength").get<size_t>();
    if (off > bin.size() || len > bin.size() - off) return 0;
    int w = 0, h = 0;
    if (!probe_image_size(bin.data() + off, len, &w, &h)) return 0;
    return std::max(w, h);
  } catch (const json::exception&) {
    return 0;
  } catch (const std::out_of_range&) {
    return 0;
  }
}

// An accessor's elements, tightly packed (from the BIN chunk, bounds-checked).
Result<std::vector<std::uint8_t>> read_accessor(const json& doc, const json& acc,
                                                const std::vector<std::uint8_t>& bin) {
  if (acc.contains("sparse")) return cannot("sparse accessors are not compressed");
  const size_t count = acc.at("count").get<size_t>();
  const size_t elem = component_size(acc.at("componentType").get<int>()) *
                      static_cast<size_t>(component_count(acc.at("type").get<std::string>()));
  if (elem == 0) return cannot("accessor of unknown type");
  const json& view = doc.at("bufferViews").at(index_of(acc.at("bufferView")));
  if (view.value("buffer", size_t(0)) != 0) return cannot("only single-buffer GLBs are compressed");
  const size_t stride = view.value("byteStride", size_t(0)) ? view["byteStride"].get<size_t>() : elem;
  const size_t start = view.value("byteOffset", size_t(0)) + acc.value("byteOffset", size_t(0));
  const size_t len = view.at("byteLength").get<size_t>();
  if (count == 0 || stride < elem || start > bin.size() || (count - 1) * stride + elem > len ||
      view.value("byteOffset", size_t(0)) + len > bin.size())
    return cannot("accessor past its bufferView");
  std::vector<std::uint8_t> out(count * elem);
  for (size_t i = 0; i < count; ++i) std::memcpy(out.data() + i * elem, bin.data() + start + i * stride, elem);
  return out;
}

std::vector<std::uint32_t> widen_indices(const std::vector<std::uint8_t>& raw, int component_type) {
  const size_t w = component_size(component_type);
  std::vector<std::uint32_t> idx(raw.size() / w);
  for (size_t i = 0; i < idx.size(); ++i) {
    std::uint32_t v = 0;
    for (size_t b = 0; b < w; ++b) v |= std::uint32_t(raw[i * w + b]) << (8 * b);
    idx[i] = v;
  }
  return idx;
}

draco_codec::AttributeIn::Semantic semantic_of(const std::string& name) {
  using S = draco_codec::AttributeIn::Semantic;
  if (name == "POSITION") return S::kPosition;
  if (name.rfind("TEXCOORD_", 0) == 0) return S::kTexCoord;
  if (name.rfind("COLOR_", 0) == 0) return S::kColor;
  if (name == "NORMAL") return S::kNormal;
  return S::kGeneric;
}

// Largest per-axis range of float values, `components` a value.
double largest_range(const float* v, size_t count, int components) {
  double range = 0;
  for (int k = 0; k < components; ++k) {
    float lo = std::numeric_limits<float>::infinity(), hi = -lo;
    for (size_t i = 0; i < count; ++i)
      lo = std::min(lo, v[i * components + k]), hi = std::max(hi, v[i * components + k]);
    range = std::max(range, double(hi) - double(lo));
  }
  return range;
}

// Every accessor index a primitive refers to, counted over the document (a shared one is not compressed).
void count_uses(const json& doc, std::map<size_t, int>* uses) {
  for (const auto& mesh : doc.value("meshes", json::array()))
    for (const auto& prim : mesh.value("primitives", json::array())) {
      if (prim.contains("attributes"))
        for (const auto& [name, a] : prim["attributes"].items()) ++(*uses)[index_of(a)];
      if (prim.contains("indices")) ++(*uses)[index_of(prim["indices"])];
      for (const auto& target : prim.value("targets", json::array()))
        for (const auto& [name, a] : target.items()) ++(*uses)[index_of(a)];
    }
}

// Keeps the bufferViews still referenced (images, accessors with a bufferView), renumbered, their bytes copied into
// *bin; returns the new views array.
json keep_referenced_views(json& doc, const std::vector<std::uint8_t>& in_bin, std::vector<std::uint8_t>* bin) {
  json& views = doc["bufferViews"];
  std::map<size_t, size_t> remap;
  json kept = json::array();
  auto keep = [&](json& ref) {
    const size_t v = index_of(ref);
    auto it = remap.find(v);
    if (it == remap.end()) {
      json view = views.at(v);
      const size_t off = view.value("byteOffset", size_t(0)), len = view.at("byteLength").get<size_t>();
      if (off > in_bin.size() || len > in_bin.size() - off) throw std::out_of_range("bufferView past the BIN chunk");
      align4(*bin);
      view["buffer"] = 0;
      view["byteOffset"] = bin->size();
      bin->insert(bin->end(), in_bin.begin() + off, in_bin.begin() + off + len);
      it = remap.emplace(v, kept.size()).first;
      kept.push_back(view);
    }
    ref = it->second;
  };
  for (auto& image : doc["images"])
    if (image.contains("bufferView")) keep(image["bufferView"]);
  for (auto& acc : doc["accessors"]) {
    if (acc.contains("bufferView")) keep(acc["bufferView"]);
    if (acc.contains("sparse")) {
      keep(acc["sparse"]["indices"]["bufferView"]);
      keep(acc["sparse"]["values"]["bufferView"]);
    }
  }
  return kept;
}

// A 64-bit hash of everything that decides a primitive's Draco bitstream: libstdc++'s string hash (MurmurHash2 64A,
// eight bytes a step) of each part, chained. FNV-1a's byte-a-step loop took 0.17 ms a call on a realtime frame's
// geometry, and a budgeted frame calls it twice (its measurement and its final write).
std::uint64_t cache_key(const draco_codec::MeshIn& m, const std::vector<std::vector<std::uint8_t>>& data) {
  std::uint64_t h = 1469598103934665603ull;
  auto mix = [&](const void* p, size_t n) {
    const std::uint64_t part = std::hash<std::string_view>{}(std::string_view(static_cast<const char*>(p), n));
    h = (h ^ part) * 0x9e3779b97f4a7c15ull;
    h ^= h >> 29;
  };
  auto mix_int = [&](long long v) { mix(&v, sizeof v); };
  mix_int(static_cast<long long>(m.num_points)), mix_int(m.encode_speed), mix_int(m.decode_speed);
  for (size_t k = 0; k < m.attributes.size(); ++k) {
    const auto& a = m.attributes[k];
    mix_int(static_cast<int>(a.semantic)), mix_int(a.component_type), mix_int(a.components);
    mix_int(a.normalized), mix_int(a.quantization_bits);
    mix_int(static_cast<long long>(data[k].size()));
    mix(data[k].data(), data[k].size());
  }
  mix_int(static_cast<long long>(m.num_indices));
  mix(m.indices, m.num_indices * sizeof(std::uint32_t));
  return h;
}

// Encodes one primitive. The accessors get the counts and POSITION bounds of what a reader will see: from the
// encoder when every point is referenced (draco_codec::Encoded: its tracked counts and its quantizer's extremes, no
// decode; a decode was 0.9 ms of a 21 ms realtime frame), else from one decode of the bitstream.
Result<std::shared_ptr<const DracoCache::Entry>> compress_primitive(const draco_codec::MeshIn& mesh_in,
                                                                    const std::vector<std::string>& names) {
  std::string error;
  draco_codec::Encoded enc = draco_codec::encode_mesh(mesh_in, &error);
  if (enc.bytes.empty()) return make_error(ErrorCode::kInternal, error);
  auto e = std::make_shared<DracoCache::Entry>();
  auto set_bounds = [&](const auto& lo, const auto& hi) {
    e->position_min.assign(lo.begin(), lo.end());
    e->position_max.assign(hi.begin(), hi.end());
  };
  // Every point referenced: then the decoded values are the input's (a non-manifold vertex's extra points repeat
  // its value), so their extremes are the quantizer's.
  std::vector<std::uint8_t> referenced(mesh_in.num_points, 0);
  for (size_t i = 0; i < mesh_in.num_indices; ++i) referenced[mesh_in.indices[i]] = 1;
  const bool all_referenced = std::find(referenced.begin(), referenced.end(), 0) == referenced.end();
  if (all_referenced && enc.num_points >= mesh_in.num_points && enc.num_faces == mesh_in.num_indices / 3) {
    e->num_points = enc.num_points;
    e->num_indices = 3 * enc.num_faces;
    for (size_t k = 0; k < names.size(); ++k)
      if (names[k] == "POSITION" && mesh_in.attributes[k].component_type == 5126 && !enc.decoded_min[k].empty())
        set_bounds(enc.decoded_min[k], enc.decoded_max[k]);
  } else {
    std::vector<draco_codec::AttributeRequest> requests;
    for (size_t k = 0; k < names.size(); ++k)
      requests.push_back(
          {enc.attribute_ids[k], mesh_in.attributes[k].component_type, mesh_in.attributes[k].components});
    draco_codec::Decoded dec;
    if (!draco_codec::decode_mesh(enc.bytes.data(), enc.bytes.size(), requests, 3 * mesh_in.num_indices,
                                  mesh_in.num_indices / 3, &dec, &error))
      return make_error(ErrorCode::kInternal, "draco compress: own output does not decode: " + error);
    if (dec.indices.size() != mesh_in.num_indices)
      return make_error(ErrorCode::kInternal, "draco compress: the encoder changed the triangle count");
    e->num_points = dec.num_points;
    e->num_indices = dec.indices.size();
    for (size_t k = 0; k < names.size(); ++k)
      if (names[k] == "POSITION" && mesh_in.attributes[k].component_type == 5126) {
        const float* p = reinterpret_cast<const float*>(dec.attributes[k].data());
        std::vector<double> lo(3, std::numeric_limits<double>::infinity()),
            hi(3, -std::numeric_limits<double>::infinity());
        for (size_t i = 0; i < dec.num_points; ++i)
          for (int c = 0; c < 3; ++c)
            lo[c] = std::min<double>(lo[c], p[3 * i + c]), hi[c] = std::max<double>(hi[c], p[3 * i + c]);
        set_bounds(lo, hi);
      }
  }
  e->bytes = std::move(enc.bytes);
  e->attribute_ids = std::move(enc.attribute_ids);
  return std::shared_ptr<const DracoCache::Entry>(std::move(e));
}

}  // namespace

bool uses_draco(const GlbChunks& in) { return in.json.find(kExt) != std::string::npos; }

Result<GlbChunks> draco_compress(const GlbChunks& in, const DracoOptions& options) {
  try {
    json doc = json::parse(in.json);
    if (!doc.contains("images")) doc["images"] = json::array();
    if (!doc.contains("accessors")) doc["accessors"] = json::array();
    std::map<size_t, int> uses;
    count_uses(doc, &uses);
    json& accessors = doc["accessors"];
    struct Encoded {
      std::vector<std::uint8_t> bytes;
      json* ext;
    };
    std::vector<Encoded> encoded;
    for (auto& mesh : doc["meshes"])
      for (auto& prim : mesh["primitives"]) {
        if (prim.value("mode", 4) != 4 || prim.contains("targets")) continue;
        bool shared = false;
        for (const auto& [name, a] : prim.at("attributes").items()) shared = shared || uses[index_of(a)] > 1;
        if (prim.contains("indices")) shared = shared || uses[index_of(prim["indices"])] > 1;
        if (shared || !prim["attributes"].contains("POSITION")) continue;
        const size_t num_points = accessors.at(index_of(prim["attributes"]["POSITION"])).at("count").get<size_t>();

        std::vector<std::uint32_t> indices;
        if (prim.contains("indices")) {
          const json& acc = accessors.at(index_of(prim["indices"]));
          auto raw = read_accessor(doc, acc, in.bin);
          if (!raw) return raw.error();
          indices = widen_indices(*raw, acc.at("componentType").get<int>());
        } else {
          indices.resize(num_points);
          for (size_t i = 0; i < num_points; ++i) indices[i] = static_cast<std::uint32_t>(i);
        }
        draco_codec::MeshIn mesh_in;
        mesh_in.num_points = num_points;
        mesh_in.encode_speed = options.encode_speed;
        mesh_in.decode_speed = options.decode_speed;
        std::vector<std::vector<std::uint8_t>> data;
        std::vector<std::string> names;
        for (const auto& [name, a] : prim["attributes"].items()) {
          const json& acc = accessors.at(index_of(a));
          if (acc.at("count").get<size_t>() != num_points) return cannot(name + " count differs from POSITION's");
          auto raw = read_accessor(doc, acc, in.bin);
          if (!raw) return raw.error();
          data.push_back(std::move(*raw));
          names.push_back(name);
        }
        for (size_t k = 0; k < names.size(); ++k) {
          const json& acc = accessors.at(index_of(prim["attributes"][names[k]]));
          draco_codec::AttributeIn a;
          a.semantic = semantic_of(names[k]);
          a.component_type = acc.at("componentType").get<int>();
          a.components = component_count(acc.at("type").get<std::string>());
          a.normalized = acc.value("normalized", false);
          a.data = data[k].data();
          if (a.component_type == 5126) {
            const double range =
                largest_range(reinterpret_cast<const float*>(data[k].data()), num_points, a.components);
            if (a.semantic == draco_codec::AttributeIn::Semantic::kPosition) {
              a.quantization_bits = bits_for(range, options.position_step_m);
            } else if (a.semantic == draco_codec::AttributeIn::Semantic::kTexCoord) {
              const int side = texture_side_for(doc, prim, std::atoi(names[k].c_str() + 9), in.bin);
              a.quantization_bits = side > 0 ? bits_for(range * side, options.uv_step_texels) : 12;
            } else {
              a.quantization_bits = 12;
            }
          }
          mesh_in.attributes.push_back(a);
        }
        mesh_in.indices = indices.data();
        mesh_in.num_indices = indices.size();
        const std::uint64_t key = options.cache ? cache_key(mesh_in, data) : 0;
        std::shared_ptr<const DracoCache::Entry> compressed = options.cache ? options.cache->find(key) : nullptr;
        if (!compressed) {
          auto made = compress_primitive(mesh_in, names);
          if (!made) return made.error();
          compressed = std::move(*made);
          if (options.cache) options.cache->put(key, compressed);
        }
        json ext = {{"attributes", json::object()}};
        for (size_t k = 0; k < names.size(); ++k) {
          json& acc = accessors[index_of(prim["attributes"][names[k]])];
          acc.erase("bufferView");
          acc.erase("byteOffset");
          acc["count"] = compressed->num_points;
          acc.erase("min");
          acc.erase("max");
          if (names[k] == "POSITION" && !compressed->position_min.empty()) {
            acc["min"] = compressed->position_min;
            acc["max"] = compressed->position_max;
          }
          ext["attributes"][names[k]] = compressed->attribute_ids[k];
        }
        json index_acc = {{"componentType", compressed->num_points <= 65535 ? 5123 : 5125},
                          {"count", compressed->num_indices},
                          {"type", "SCALAR"}};
        if (prim.contains("indices")) {
          accessors[index_of(prim["indices"])] = index_acc;
        } else {
          prim["indices"] = accessors.size();
          accessors.push_back(index_acc);
        }
        prim["extensions"][kExt] = ext;
        encoded.push_back({compressed->bytes, &prim["extensions"][kExt]});
      }
    if (encoded.empty()) return in;
    GlbChunks out;
    out.has_bin = true;
    json views = keep_referenced_views(doc, in.bin, &out.bin);
    for (Encoded& e : encoded) {
      align4(out.bin);
      (*e.ext)["bufferView"] = views.size();
      views.push_back({{"buffer", 0}, {"byteOffset", out.bin.size()}, {"byteLength", e.bytes.size()}});
      out.bin.insert(out.bin.end(), e.bytes.begin(), e.bytes.end());
    }
    align4(out.bin);
    doc["bufferViews"] = views;
    if (doc["images"].empty()) doc.erase("images");
    doc["buffers"] = json::array({json{{"byteLength", out.bin.size()}}});
    require_extension(doc, kExt);
    out.json = doc.dump();
    return out;
  } catch (const json::exception& e) {
    return cannot(std::string("malformed JSON: ") + e.what());
  } catch (const std::out_of_range& e) {
    return cannot(e.what());
  }
}

Result<GlbChunks> draco_decompress(const GlbChunks& in, const GlbDecodeLimits& limits) {
  if (!uses_draco(in)) return in;
  try {
    json doc = json::parse(in.json);
    if (!doc.is_object()) return bad("JSON is not an object");
    if (!lists_extension(doc, "extensionsUsed", kExt)) return in;
    json& views = doc.at("bufferViews");
    json& accessors = doc.at("accessors");
    if (!views.is_array() || !accessors.is_array()) return bad("bufferViews/accessors are not arrays");
    GlbChunks out = in;
    out.has_bin = true;
    size_t vertices = 0, triangles = 0, decoded_bytes = 0;
    std::set<size_t> decoded_accessors;
    if (!doc.contains("meshes") || !doc["meshes"].is_array()) return bad("no meshes array");
    for (auto& mesh : doc["meshes"])
      for (auto& prim : mesh.at("primitives")) {
        if (!prim.is_object() || !prim.contains("extensions") || !prim["extensions"].is_object() ||
            !prim["extensions"].contains(kExt))
          continue;
        const json& ext = prim["extensions"][kExt];
        if (prim.value("mode", 4) != 4) return bad("only triangle lists are decoded");
        if (!prim.contains("indices")) return bad("a Draco primitive needs an indices accessor");
        const size_t view_index = index_of(ext.at("bufferView"));
        const json& view = views.at(view_index);
        if (view.value("buffer", size_t(0)) != 0) return bad("Draco data must be in the BIN chunk");
        const size_t off = view.value("byteOffset", size_t(0)), len = view.at("byteLength").get<size_t>();
        if (off > in.bin.size() || len > in.bin.size() - off) return bad("Draco bufferView past the BIN chunk");

        // Declared counts, held to the limits before anything is decoded.
        const size_t index_acc = index_of(prim["indices"]);
        json& iacc = accessors.at(index_acc);
        const size_t index_count = iacc.at("count").get<size_t>();
        const int index_type = iacc.at("componentType").get<int>();
        if (index_count % 3 != 0 || (index_type != 5121 && index_type != 5123 && index_type != 5125) ||
            iacc.value("type", std::string()) != "SCALAR")
          return bad("indices must be SCALAR unsigned integers, a multiple of 3");
        const json& attrs = prim.at("attributes");
        if (!attrs.is_object() || !attrs.contains("POSITION")) return bad("a Draco primitive needs POSITION");
        const size_t num_points = accessors.at(index_of(attrs["POSITION"])).at("count").get<size_t>();
        const size_t num_faces = index_count / 3;
        if (num_points > limits.max_vertices - std::min(vertices, limits.max_vertices) ||
            num_faces > limits.max_triangles - std::min(triangles, limits.max_triangles))
          return bad("Draco primitives declare more than the limit of " + std::to_string(limits.max_vertices) +
                     " vertices or " + std::to_string(limits.max_triangles) + " triangles");
        vertices += num_points;
        triangles += num_faces;
        auto header = read_draco_header(in.bin.data() + off, len);
        if (!header) return header.error();
        if (header->num_faces != num_faces)
          return bad("Draco data has " + std::to_string(header->num_faces) + " faces, the indices accessor " +
                     std::to_string(num_faces));
        if (header->edgebreaker ? header->num_vertices > 3 * std::uint64_t(num_faces)
                                : header->num_vertices != num_points)
          return bad("Draco data has " + std::to_string(header->num_vertices) + " vertices for " +
                     std::to_string(num_points) + " declared points");

        std::vector<draco_codec::AttributeRequest> requests;
        std::vector<size_t> targets;
        size_t primitive_bytes = index_count * 4;
        for (const auto& [name, id] : ext.at("attributes").items()) {
          if (!attrs.contains(name)) return bad("Draco attribute " + name + " is not an attribute of the primitive");
          const size_t a = index_of(attrs[name]);
          const json& acc = accessors.at(a);
          if (acc.contains("sparse")) return bad("a Draco accessor cannot be sparse");
          if (acc.at("count").get<size_t>() != num_points) return bad(name + " count differs from POSITION's");
          const int type = acc.at("componentType").get<int>();
          const int comps = component_count(acc.at("type").get<std::string>());
          if (component_size(type) == 0 || comps < 1 || comps > 4) return bad(name + " has an unsupported type");
          if (!id.is_number_integer() || id.get<long long>() < 0 || id.get<long long>() > 255)
            return bad("Draco attribute id of " + name + " is not in 0..255");
          if (decoded_accessors.count(a)) return bad("an accessor is decoded twice");
          const size_t bytes = num_points * ((component_size(type) * comps + 3) & ~size_t(3));
          primitive_bytes += bytes;
          requests.push_back({id.get<int>(), type, comps});
          targets.push_back(a);
        }
        for (const auto& [name, a] : attrs.items())
          if (!ext["attributes"].contains(name)) return bad(name + " is not in the Draco data");
        if (primitive_bytes > limits.max_draco_bytes - std::min(decoded_bytes, limits.max_draco_bytes))
          return bad("decoded data over the limit of " + std::to_string(limits.max_draco_bytes) + " bytes");
        decoded_bytes += primitive_bytes;

        draco_codec::Decoded dec;
        std::string error;
        if (!draco_codec::decode_mesh(in.bin.data() + off, len, requests, num_points, num_faces, &dec, &error))
          return bad(error);
        if (dec.num_points != num_points || dec.indices.size() != index_count)
          return bad("Draco data decodes to " + std::to_string(dec.num_points) + " points and " +
                     std::to_string(dec.indices.size() / 3) + " faces, the accessors declare " +
                     std::to_string(num_points) + " and " + std::to_string(num_faces));

        // Decoded data into new bufferViews (vertex attributes padded to 4 bytes a value).
        for (size_t r = 0; r < requests.size(); ++r) {
          const size_t elem = component_size(requests[r].component_type) * requests[r].components;
          const size_t stride = (elem + 3) & ~size_t(3);
          align4(out.bin);
          const size_t at = out.bin.size();
          out.bin.resize(at + stride * num_points, 0);
          for (size_t i = 0; i < num_points; ++i)
            std::memcpy(out.bin.data() + at + i * stride, dec.attributes[r].data() + i * elem, elem);
          views.push_back(
              {{"buffer", 0}, {"byteOffset", at}, {"byteLength", stride * num_points}, {"byteStride", stride}});
          json& acc = accessors[targets[r]];
          acc["bufferView"] = views.size() - 1;
          acc["byteOffset"] = 0;
          decoded_accessors.insert(targets[r]);
        }
        const size_t iw = component_size(index_type);
        align4(out.bin);
        const size_t at = out.bin.size();
        out.bin.resize(at + iw * index_count);
        for (size_t i = 0; i < index_count; ++i) {
          const std::uint32_t v = dec.indices[i];
          if (iw < 4 && v >= (std::uint32_t(1) << (8 * iw)))
            return bad("a decoded index does not fit the indices type");
          for (size_t b = 0; b < iw; ++b) out.bin[at + i * iw + b] = static_cast<std::uint8_t>(v >> (8 * b));
        }
        views.push_back({{"buffer", 0}, {"byteOffset", at}, {"byteLength", iw * index_count}});
        iacc["bufferView"] = views.size() - 1;
        iacc["byteOffset"] = 0;
        prim["extensions"].erase(kExt);
        if (prim["extensions"].empty()) prim.erase("extensions");
      }
    align4(out.bin);
    if (!doc.contains("buffers") || !doc["buffers"].is_array() || doc["buffers"].empty() ||
        !doc["buffers"][0].is_object())
      return bad("no buffer for the BIN chunk");
    doc["buffers"][0]["byteLength"] = out.bin.size();
    drop_extension(doc, kExt);
    out.json = doc.dump();
    return out;
  } catch (const json::exception& e) {
    return bad(std::string("malformed JSON: ") + e.what());
  } catch (const std::out_of_range& e) {
    return bad(std::string("malformed document: ") + e.what());
  }
}

}  // namespace rgbdcast::glb

namespace rgbdcast {

std::shared_ptr<const DracoCache::Entry> DracoCache::find(std::uint64_t key) const {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& [k, e] : entries_)
    if (k == key) {
      ++hits_;
      return e;
    }
  return nullptr;
}

size_t DracoCache::hits() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return hits_;
}

void DracoCache::put(std::uint64_t key, std::shared_ptr<const Entry> entry) {
  std::lock_guard<std::mutex> lock(mutex_);
  entries_.emplace_back(key, std::move(entry));
  if (entries_.size() > kKeep) entries_.erase(entries_.begin());
}

}  // namespace rgbdcast
