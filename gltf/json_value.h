#pragma once
// nlohmann::json <-> tinygltf::Value, for glTF extras and extensions.
#include <nlohmann/json.hpp>
#include <tiny_gltf.h>

namespace rgbdcast::glb {

tinygltf::Value to_value(const nlohmann::json& j);
nlohmann::json to_json(const tinygltf::Value& v);

}  // namespace rgbdcast::glb
