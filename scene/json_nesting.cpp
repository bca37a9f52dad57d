#include "scene/json_nesting.h"

namespace rgbdcast {

Status check_json_nesting(std::string_view text, size_t max_bytes, int max_depth, const std::string& what) {
  if (text.size() > max_bytes)
    return make_error(ErrorCode::kInvalidInput, what + ": JSON is " + std::to_string(text.size()) +
                                                    " bytes, over the limit of " + std::to_string(max_bytes));
  int depth = 0;
  bool in_string = false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\')
        ++i;  // the escaped character cannot close the string (\uXXXX digits are harmless)
      else if (c == '"')
        in_string = false;
      continue;
    }
    switch (c) {
      case '"':
        in_string = true;
        break;
      case '[':
      case '{':
        if (++depth > max_depth)
          return make_error(ErrorCode::kInvalidInput,
                            what + ": JSON nested deeper than " + std::to_string(max_depth) + " levels");
        break;
      case ']':
      case '}':
        if (depth > 0) --depth;  // unbalanced text is the parser's to reject
        break;
      default:
        break;
    }
  }
  return ok_status();
}

}  // namespace rgbdcast
