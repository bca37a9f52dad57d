#include "tests/gltf/hostile_glbs.h"

#include "gltf/glb_container.h"
#include "gltf/gltf_io.h"
#include "tests/gltf/sample_scenes.h"

namespace rgbdcast::test {
namespace {

nlohmann::json json_of(const Bytes& glb) {
  auto chunks = glb::parse_glb(glb.data(), glb.size());
  return nlohmann::json::parse(chunks->json);
}

int first_position_accessor(const nlohmann::json& doc) {
  return doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"].get<int>();
}

}  // namespace

Bytes plain_sample_glb() {
  GlbWriteOptions o;
  o.quantize = false;
  o.meshopt = false;
  return encode_glb(sample_scene(), o).value();
}

Bytes edit_glb(const Bytes& glb, const std::function<void(nlohmann::json&)>& edit) {
  auto chunks = glb::parse_glb(glb.data(), glb.size());
  nlohmann::json doc = nlohmann::json::parse(chunks->json);
  edit(doc);
  return glb::pack_glb(doc.dump(), chunks->bin);
}

Bytes glb_with_buffer_uri(const std::string& uri) {
  return edit_glb(plain_sample_glb(), [&](nlohmann::json& d) { d["buffers"][0]["uri"] = uri; });
}

Bytes glb_with_image_uri(const std::string& uri) {
  return edit_glb(plain_sample_glb(), [&](nlohmann::json& d) {
    d["images"][0].erase("bufferView");
    d["images"][0].erase("mimeType");
    d["images"][0]["uri"] = uri;
  });
}

Bytes glb_with_nested_extras(int depth) {
  const Bytes glb = plain_sample_glb();
  auto chunks = glb::parse_glb(glb.data(), glb.size());
  std::string json = chunks->json;
  const size_t at = json.find("\"nodes\":[{");
  std::string extras = "\"extras\":";
  for (int i = 0; i < depth; ++i) extras += "{\"a\":";
  extras += "0";
  extras.append(static_cast<size_t>(depth), '}');
  json.insert(at + 10, extras + ",");
  return glb::pack_glb(json, chunks->bin);
}

Bytes glb_with_position_count(std::uint64_t count) {
  return edit_glb(plain_sample_glb(),
                  [&](nlohmann::json& d) { d["accessors"][first_position_accessor(d)]["count"] = count; });
}

Bytes glb_without_bufferview(std::uint64_t count) {
  return edit_glb(plain_sample_glb(), [&](nlohmann::json& d) {
    auto& a = d["accessors"][first_position_accessor(d)];
    a.erase("bufferView");
    a.erase("byteOffset");
    a["count"] = count;
    a.erase("min");
    a.erase("max");
    for (auto& mesh : d["meshes"])
      for (auto& prim : mesh["primitives"]) prim.erase("indices");
  });
}

Bytes glb_with_mesh_instances(int copies) {
  return edit_glb(plain_sample_glb(), [&](nlohmann::json& d) {
    // The first node with a mesh, and `copies` siblings that instance the same mesh under the same parent.
    for (size_t i = 0; i < d["nodes"].size(); ++i) {
      if (!d["nodes"][i].contains("mesh")) continue;
      for (size_t p = 0; p < d["nodes"].size(); ++p) {
        auto& parent = d["nodes"][p];
        if (!parent.contains("children")) continue;
        bool holds = false;
        for (const auto& c : parent["children"]) holds = holds || c.get<size_t>() == i;
        if (!holds) continue;
        for (int k = 0; k < copies; ++k) {
          nlohmann::json copy = {{"mesh", d["nodes"][i]["mesh"]}};
          d["nodes"].push_back(copy);
          d["nodes"][p]["children"].push_back(d["nodes"].size() - 1);
        }
        return;
      }
    }
  });
}

size_t sample_first_mesh_vertices() {
  const auto doc = json_of(plain_sample_glb());
  return doc["accessors"][first_position_accessor(doc)]["count"].get<size_t>();
}

}  // namespace rgbdcast::test
