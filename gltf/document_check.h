#pragma once
// The structural budget of an untrusted glTF document, checked on its JSON before tinygltf sees it (tinygltf 2.7
// reads image bufferViews without a range check, copies the BIN chunk once per buffer, and opens any URI it is given).
// Contract, for a GLB whose BIN chunk holds bin_size bytes:
//  - no buffer or image has a `uri` (external files and data URIs alike): "external URI not allowed" /
//    "data URI not allowed", naming the element (buffers[1].uri), never the URI itself;
//  - at most one buffer (the BIN chunk), whose byteLength fits in the BIN chunk;
//  - every bufferView lies inside its buffer; every image has a non-empty bufferView;
//  - every accessor has a bufferView that holds byteOffset + stride x (count - 1) + element size bytes;
//  - indices are non-negative integers, lengths unsigned integers; all arithmetic is overflow-safe.
// Errors are kInvalidInput with a one-line "GLB: ..." message. Pure function of its inputs.
#include <cstddef>

#include <nlohmann/json_fwd.hpp>

#include "scene/result.h"

namespace rgbdcast::glb {

Status check_document(const nlohmann::json& doc, size_t bin_size);

}  // namespace rgbdcast::glb
