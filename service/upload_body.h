#pragma once
// Reading an upload's body, for every route that takes one (POST /v1/scenes, POST /v1/missions/<name>/keyframes):
// the bytes received count against one limit whatever the framing (Content-Length, chunked) or coding (httplib
// inflates gzip and br), 413 past it; a body cut short or malformed is 400. A frame upload (multipart/form-data) has
// the parts color, depth and intrinsics, each once (at most 8 parts). Then the frame's checks and decoding up to the
// RgbdFrame that ingest_frame reduces, so the multipart fuzz target runs the server's own code from the body bytes.
// httplib.h must be compiled with the library's flags (../shared/STACK.md): link rgbdcast_service_body.
#include <httplib.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "scene/result.h"

namespace rgbdcast {
// Declared only: input/frame.h brings Eigen, whose products do not compile after httplib.h (<resolv.h> defines
// `_res`, a parameter name in Eigen's kernels). Include input/frame.h before httplib.h to use the result.
struct RgbdFrame;
}  // namespace rgbdcast

namespace rgbdcast::service {

// The bytes of a body as they arrive: past `limit` the reading stops and `over` is set.
struct BodyBudget {
  size_t limit = 0, received = 0;
  bool over = false;
  bool take(size_t n) {
    received += n;
    over = over || received > limit;
    return !over;
  }
};

// What to answer instead of processing the body: a 4xx and its one-line detail.
struct BodyRefusal {
  int status = 400;
  std::string detail;
  bool close = true;  // the body was not read to its end: the connection must close after the answer
};

// The whole body (a GLB) into *body.
std::optional<BodyRefusal> read_whole_body(const httplib::ContentReader& reader, size_t limit,
                                           std::vector<std::uint8_t>* body);

struct FrameParts {
  std::vector<unsigned char> color;  // PNG or JPEG bytes
  std::vector<unsigned char> depth;  // 16-bit single-channel PNG bytes
  std::string intrinsics_json;
  std::optional<std::string> preset, budget_kb;  // optional form fields (their first 40 characters)
};
// A multipart frame upload's parts into *parts (400 for a repeated part, more than 8, or one of the three missing;
// `preset` and `budget_kb` are optional).
std::optional<BodyRefusal> read_frame_parts(const httplib::ContentReader& reader, size_t limit, FrameParts* parts);

// The frame checks before anything is reduced: both images PNG/JPEG no larger than max_width x max_height (from their
// headers, undecoded), the intrinsics parse with finite positive focal lengths, the images decode and agree.
// kInvalidInput, one line, no server path.
Result<RgbdFrame> decode_frame_parts(const std::vector<unsigned char>& color, const std::vector<unsigned char>& depth,
                                     const std::string& intrinsics_json, int max_width, int max_height);

}  // namespace rgbdcast::service
