#include "scene/error_text.h"

namespace rgbdcast {

std::string quote_for_error(const std::string& text, size_t max_bytes) {
  static const char* kHex = "0123456789abcdef";
  std::string out;
  for (size_t i = 0; i < text.size() && i < max_bytes; ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c >= 0x20 && c < 0x7f && c != '\\') {
      out.push_back(static_cast<char>(c));
    } else {
      out += "\\x";
      out.push_back(kHex[c >> 4]);
      out.push_back(kHex[c & 15]);
    }
  }
  return text.size() > max_bytes ? out + "..." : out;
}

std::string single_quoted_for_error(const std::string& text, size_t max_bytes) {
  // Appended, not "'" + quote_for_error(...): GCC 12 takes that operator+(const char*, std::string&&) for a restrict
  // violation (GCC bug 105651) and the test build makes warnings errors.
  std::string out = "'";
  out += quote_for_error(text, max_bytes);
  out += '\'';
  return out;
}

}  // namespace rgbdcast
