#pragma once
// Small helpers shared by the GLB compression passes (meshopt_buffers.cpp, draco_buffers.cpp).
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace rgbdcast::glb {

// Pads b with zeros to a multiple of 4 bytes (glTF's bufferView alignment).
void align4(std::vector<std::uint8_t>& b);
// Whether doc[list] ("extensionsUsed", "extensionsRequired") is an array holding `name`.
bool lists_extension(const nlohmann::json& doc, const char* list, const char* name);
// Adds `name` to doc[list] ("extensionsUsed", "extensionsRequired") once.
void add_extension_name(nlohmann::json& doc, const char* list, const char* name);
// Removes `name` from doc[list]; drops the list when it becomes empty.
void remove_extension_name(nlohmann::json& doc, const char* list, const char* name);
// Both lists at once: a required extension added, or an extension dropped from both.
void require_extension(nlohmann::json& doc, const char* name);
void drop_extension(nlohmann::json& doc, const char* name);
// Bytes of one glTF componentType (5120..5126); 0 for an unknown one.
size_t component_size(int component_type);
// Components of a glTF accessor type ("SCALAR" 1 .. "VEC4" 4, "MAT4" 16); 0 for an unknown one.
int component_count(const std::string& type);

}  // namespace rgbdcast::glb
