#include "gltf/document_check.h"

#include "gltf/pass_helpers.h"

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace rgbdcast::glb {
namespace {

using nlohmann::json;

Error bad(const std::string& what) { return make_error(ErrorCode::kInvalidInput, "GLB: " + what); }

std::string at(const char* array, size_t i) { return std::string(array) + "[" + std::to_string(i) + "]"; }

// An optional non-negative integer member: absent -> fallback; present but not one -> false.
bool uint_member(const json& o, const char* key, std::uint64_t fallback, std::uint64_t* out) {
  auto it = o.find(key);
  if (it == o.end()) {
    *out = fallback;
    return true;
  }
  if (it->is_number_unsigned()) {
    *out = it->get<std::uint64_t>();
    return true;
  }
  if (it->is_number_integer() && it->get<std::int64_t>() >= 0) {
    *out = static_cast<std::uint64_t>(it->get<std::int64_t>());
    return true;
  }
  return false;
}

// The array `key` of the document, or an empty one; false when present but not an array of objects.
bool object_array(const json& doc, const char* key, const json** out) {
  static const json empty = json::array();
  auto it = doc.find(key);
  *out = &empty;
  if (it == doc.end()) return true;
  if (!it->is_array()) return false;
  for (const auto& e : *it)
    if (!e.is_object()) return false;
  *out = &*it;
  return true;
}

Status check_uri(const json& o, const std::string& where) {
  auto it = o.find("uri");
  if (it == o.end()) return ok_status();
  if (it->is_string() && it->get_ref<const std::string&>().rfind("data:", 0) == 0)
    return bad("data URI not allowed (" + where + ".uri): a GLB keeps its data in the BIN chunk");
  return bad("external URI not allowed (" + where + ".uri): a GLB must be self-contained");
}

}  // namespace

Status check_document(const json& doc, size_t bin_size) {
  if (!doc.is_object()) return bad("the JSON chunk is not an object");
  const json *buffers, *views, *images, *accessors;
  if (!object_array(doc, "buffers", &buffers)) return bad("buffers is not an array of objects");
  if (!object_array(doc, "bufferViews", &views)) return bad("bufferViews is not an array of objects");
  if (!object_array(doc, "images", &images)) return bad("images is not an array of objects");
  if (!object_array(doc, "accessors", &accessors)) return bad("accessors is not an array of objects");

  std::vector<std::uint64_t> buffer_bytes;
  for (size_t i = 0; i < buffers->size(); ++i) {
    const json& b = (*buffers)[i];
    if (auto st = check_uri(b, at("buffers", i)); !st) return st;
    if (i > 0) return bad("only one buffer (the BIN chunk) is allowed, found " + std::to_string(buffers->size()));
    std::uint64_t len = 0;
    if (!b.contains("byteLength") || !uint_member(b, "byteLength", 0, &len))
      return bad(at("buffers", i) + ".byteLength is not a non-negative integer");
    if (len > bin_size)
      return bad(at("buffers", i) + ".byteLength " + std::to_string(len) + " is past the BIN chunk of " +
                 std::to_string(bin_size) + " bytes");
    buffer_bytes.push_back(len);
  }

  std::vector<std::uint64_t> view_bytes, view_stride;
  for (size_t i = 0; i < views->size(); ++i) {
    const json& v = (*views)[i];
    std::uint64_t buffer = 0, offset = 0, length = 0, stride = 0;
    if (!v.contains("buffer") || !uint_member(v, "buffer", 0, &buffer) || buffer >= buffer_bytes.size())
      return bad(at("bufferViews", i) + ".buffer is not a buffer index");
    if (!uint_member(v, "byteOffset", 0, &offset) || !v.contains("byteLength") ||
        !uint_member(v, "byteLength", 0, &length) || !uint_member(v, "byteStride", 0, &stride))
      return bad(at("bufferViews", i) + ": byteOffset, byteLength and byteStride must be non-negative integers");
    if (offset > buffer_bytes[buffer] || length > buffer_bytes[buffer] - offset)
      return bad(at("bufferViews", i) + " runs past its buffer");
    if (stride != 0 && (stride < 4 || stride > 252 || stride % 4 != 0))
      return bad(at("bufferViews", i) + ".byteStride must be 4..252 and a multiple of 4");
    view_bytes.push_back(length);
    view_stride.push_back(stride);
  }

  for (size_t i = 0; i < images->size(); ++i) {
    const json& img = (*images)[i];
    if (auto st = check_uri(img, at("images", i)); !st) return st;
    std::uint64_t view = 0;
    if (!img.contains("bufferView") || !uint_member(img, "bufferView", 0, &view) || view >= view_bytes.size())
      return bad(at("images", i) + " has no bufferView");
    if (view_bytes[view] == 0) return bad(at("images", i) + " has an empty bufferView");
  }

  for (size_t i = 0; i < accessors->size(); ++i) {
    const json& a = (*accessors)[i];
    std::uint64_t view = 0, count = 0, offset = 0, ctype = 0;
    if (!a.contains("bufferView"))
      return bad(at("accessors", i) + " has no bufferView (zero-filled accessors are not accepted)");
    if (!uint_member(a, "bufferView", 0, &view) || view >= view_bytes.size())
      return bad(at("accessors", i) + ".bufferView is not a bufferView index");
    if (!a.contains("count") || !uint_member(a, "count", 0, &count) || count == 0)
      return bad(at("accessors", i) + ".count must be a positive integer");
    if (!uint_member(a, "byteOffset", 0, &offset))
      return bad(at("accessors", i) + ".byteOffset must be a non-negative integer");
    const size_t csize = a.contains("componentType") && uint_member(a, "componentType", 0, &ctype) && ctype <= 0xffff
                             ? component_size(static_cast<int>(ctype))
                             : 0;
    const size_t comps =
        a.contains("type") && a["type"].is_string() ? component_count(a["type"].get<std::string>()) : 0;
    if (csize == 0 || comps == 0) return bad(at("accessors", i) + " has an unknown componentType or type");
    const std::uint64_t elem = csize * comps;
    const std::uint64_t stride = view_stride[view] ? view_stride[view] : elem;
    const std::uint64_t have = view_bytes[view];
    // offset + stride * (count - 1) + elem <= have, without overflow (count, offset, have are < 2^64).
    if (offset > have || elem > have - offset || (count - 1) > (have - offset - elem) / stride)
      return bad(at("accessors", i) + ": " + std::to_string(count) + " elements do not fit in its bufferView of " +
                 std::to_string(have) + " bytes");
  }
  return ok_status();
}

}  // namespace rgbdcast::glb
