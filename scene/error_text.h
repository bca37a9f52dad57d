#pragma once
// Outside text in error messages (scene/result.h: an Error's message is one line).
#include <cstddef>
#include <string>

namespace rgbdcast {

// Outside text (a client's parameter, a name read from a file) quoted in an error message: at most max_bytes of it
// ("..." after a cut), every byte outside printable ASCII (control characters such as a decoded %0A, DEL, backslash,
// bytes of UTF-8) written as \xNN, so the message stays one printable line whatever the input.
std::string quote_for_error(const std::string& text, size_t max_bytes = 40);
// The same between single quotes: 'text'.
std::string single_quoted_for_error(const std::string& text, size_t max_bytes = 40);

}  // namespace rgbdcast
