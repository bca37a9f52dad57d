#pragma once
// One shape for every error the service answers: {"error": "<short code>", "detail": "<one line>"}, and one map from
// the library's ErrorCode to an HTTP status.
#include <string>

#include "scene/error_text.h"
#include "scene/result.h"

namespace rgbdcast::service {

// kNotFound 404, kInvalidArgument 400, kInvalidInput and kEmpty 422, kUnavailable 503, kIo and kInternal 500.
int http_status_for(ErrorCode code);
// A short machine-readable name for a status: 400 "bad_request", 404 "not_found", 413 "payload_too_large", ...
const char* error_name_for(int status);
// The JSON body (with a trailing newline).
std::string error_body(int status, const std::string& detail);

}  // namespace rgbdcast::service

namespace rgbdcast::service {
// An error text with server paths taken out: every word that starts with '/' and holds a second '/' (an absolute
// path, "/home/x/store/scenes/.tmp-1.json") becomes "<path>". For details that quote library errors.
std::string redact_paths(const std::string& text);
}  // namespace rgbdcast::service

namespace rgbdcast::service {
using rgbdcast::quote_for_error;  // scene/error_text.h: what a client sent, quoted in an error text
using rgbdcast::single_quoted_for_error;
}  // namespace rgbdcast::service
