#include "gltf/pass_helpers.h"

namespace rgbdcast::glb {

void align4(std::vector<std::uint8_t>& b) {
  while (b.size() % 4) b.push_back(0);
}

bool lists_extension(const nlohmann::json& doc, const char* list, const char* name) {
  auto it = doc.find(list);
  if (it == doc.end() || !it->is_array()) return false;
  for (const auto& e : *it)
    if (e == name) return true;
  return false;
}

void add_extension_name(nlohmann::json& doc, const char* list, const char* name) {
  nlohmann::json& arr = doc[list];
  if (!arr.is_array()) arr = nlohmann::json::array();
  for (const auto& e : arr)
    if (e == name) return;
  arr.push_back(name);
}

void remove_extension_name(nlohmann::json& doc, const char* list, const char* name) {
  if (!doc.contains(list) || !doc[list].is_array()) return;
  nlohmann::json out = nlohmann::json::array();
  for (const auto& e : doc[list])
    if (e != name) out.push_back(e);
  if (out.empty())
    doc.erase(list);
  else
    doc[list] = out;
}

void require_extension(nlohmann::json& doc, const char* name) {
  add_extension_name(doc, "extensionsUsed", name);
  add_extension_name(doc, "extensionsRequired", name);
}

void drop_extension(nlohmann::json& doc, const char* name) {
  remove_extension_name(doc, "extensionsUsed", name);
  remove_extension_name(doc, "extensionsRequired", name);
}

size_t component_size(int type) {
  switch (type) {
    case 5120:
    case 5121:
      return 1;
    case 5122:
    case 5123:
      return 2;
    case 5125:
    case 5126:
      return 4;
    default:
      return 0;
  }
}

int component_count(const std::string& type) {
  if (type == "SCALAR") return 1;
  if (type == "VEC2") return 2;
  if (type == "VEC3") return 3;
  if (type == "VEC4" || type == "MAT2") return 4;
  if (type == "MAT3") return 9;
  if (type == "MAT4") return 16;
  return 0;
}

}  // namespace rgbdcast::glb
