#pragma once
// Compressed answers that the service makes once and sends many times. httplib (built with zlib and brotli) would
// otherwise compress every text or JSON answer itself, per request, with brotli at its slowest quality when the
// client accepts br: seconds of a core for a few hundred kB up (three.core.js: 5.5 s; the 0.94 MB tileset.json of
// a 5,000-keyframe mission: 1.5 s). A body sent through send_shared() is a content provider of known length, which
// httplib sends as it is.
#include <httplib.h>

#include <memory>
#include <string>
#include <string_view>

namespace rgbdcast::service {

// gzip (RFC 1952) of `in` at zlib `level` (1..9), or "" on failure.
std::string gzip(std::string_view in, int level);

// Whether the request's Accept-Encoding offers gzip.
bool accepts_gzip(const httplib::Request& req);

// Sends `body` (kept alive by the answer) as it is, with the given media type.
void send_shared(httplib::Response& res, std::shared_ptr<const std::string> body, const std::string& type);

}  // namespace rgbdcast::service
