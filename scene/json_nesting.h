#pragma once
// A cheap guard in front of JSON parsers that recurse (tinygltf's JSON-to-Value conversion overflows the stack at
// ~15,000 levels): one pass over the text counting '[' and '{' depth, skipping strings and their escapes.
// Contract: O(n), no allocation, never reads past text. It is not a validator: malformed text that stays shallow
// passes, and the parser that follows rejects it. Returns kInvalidInput naming `what` when the text is larger than
// max_bytes or nests deeper than max_depth (depth 1 = one top-level object or array).
#include <cstddef>
#include <string>
#include <string_view>

#include "scene/result.h"

namespace rgbdcast {

inline constexpr int kDefaultMaxJsonDepth = 64;

Status check_json_nesting(std::string_view text, size_t max_bytes, int max_depth, const std::string& what);

}  // namespace rgbdcast
