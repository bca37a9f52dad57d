#include "input/frame_source.h"  // first: Eigen before httplib.h (upload_body.h)
#include "service/upload_body.h"

#include <cmath>
#include <map>

#include "input/intrinsics_io.h"
#include "service/image_header.h"

namespace rgbdcast::service {
namespace {

BodyRefusal over_limit(size_t limit) {
  return {413, "request body over the limit of " + std::to_string(limit) +
                   " bytes (--max-body-mib), counted after "
                   "decoding"};
}

Status check_image_size(const std::vector<unsigned char>& bytes, const char* part, int max_width, int max_height) {
  auto size = peek_image_size(bytes.data(), bytes.size());
  if (!size) return make_error(ErrorCode::kInvalidInput, std::string(part) + ": " + size.error().message);
  if (size->width > max_width || size->height > max_height)
    return make_error(ErrorCode::kInvalidInput, std::string(part) + ": " + std::to_string(size->width) + "x" +
                                                    std::to_string(size->height) + " is over the frame limit of " +
                                                    std::to_string(max_width) + "x" + std::to_string(max_height) +
                                                    " (--max-frame)");
  return ok_status();
}

}  // namespace

std::optional<BodyRefusal> read_whole_body(const httplib::ContentReader& reader, size_t limit,
                                           std::vector<std::uint8_t>* body) {
  BodyBudget budget{limit};
  const bool read = reader([&](const char* data, size_t n) {
    if (!budget.take(n)) return false;
    body->insert(body->end(), data, data + n);
    return true;
  });
  if (read) return std::nullopt;
  if (budget.over) return over_limit(limit);
  return BodyRefusal{400, "request body could not be read (cut short, bad chunked framing or bad compressed data)"};
}

std::optional<BodyRefusal> read_frame_parts(const httplib::ContentReader& reader, size_t limit, FrameParts* out) {
  BodyBudget budget{limit};
  std::map<std::string, std::string> parts;
  std::string* part = nullptr;
  bool duplicate = false;
  const bool read = reader(
      [&](const httplib::MultipartFormData& file) {
        auto [it, fresh] = parts.emplace(file.name, std::string());
        duplicate = duplicate || !fresh || parts.size() > 8;
        part = &it->second;
        return !duplicate;
      },
      [&](const char* data, size_t n) {
        if (!budget.take(n)) return false;
        part->append(data, n);
        return true;
      });
  if (!read) {
    if (budget.over) return over_limit(limit);
    if (duplicate) return BodyRefusal{400, "multipart upload with a repeated part or more than 8 parts"};
    return BodyRefusal{400,
                       "request body could not be read (cut short, bad chunked framing, bad compressed data or "
                       "malformed multipart)"};
  }
  for (const char* name : {"color", "depth", "intrinsics"})
    if (!parts.count(name))
      return BodyRefusal{400,
                         std::string("multipart upload lacks the part '") + name +
                             "' (parts: color, depth, intrinsics; optional: preset, budget_kb)",
                         false};
  for (auto [name, field] : {std::pair{"preset", &out->preset}, std::pair{"budget_kb", &out->budget_kb}})
    if (parts.count(name)) *field = parts[name].substr(0, 40);
  out->color.assign(parts["color"].begin(), parts["color"].end());
  out->depth.assign(parts["depth"].begin(), parts["depth"].end());
  out->intrinsics_json = std::move(parts["intrinsics"]);
  return std::nullopt;
}

Result<RgbdFrame> decode_frame_parts(const std::vector<unsigned char>& color_bytes,
                                     const std::vector<unsigned char>& depth_bytes, const std::string& intrinsics_json,
                                     int max_width, int max_height) {
  for (const auto& [bytes, part] : {std::pair{&color_bytes, "color"}, std::pair{&depth_bytes, "depth"}}) {
    auto st = check_image_size(*bytes, part, max_width, max_height);
    if (!st) return st.error();
  }
  auto intrinsics = parse_intrinsics_json(intrinsics_json, "intrinsics");  // from memory, no paths
  if (!intrinsics) return intrinsics.error();
  {
    const Intrinsics& k = *intrinsics;
    if (!(std::isfinite(k.fx) && std::isfinite(k.fy) && k.fx > 0 && k.fy > 0))
      return make_error(ErrorCode::kInvalidInput, "intrinsics: focal lengths fx and fy must be positive numbers");
  }
  auto color = decode_color(color_bytes, "color");
  if (!color) return make_error(ErrorCode::kInvalidInput, color.error().message);
  auto depth = decode_depth16(depth_bytes, "depth");
  if (!depth) return make_error(ErrorCode::kInvalidInput, depth.error().message);
  auto frame = make_frame(*color, *depth, *intrinsics);
  if (!frame) return make_error(ErrorCode::kInvalidInput, frame.error().message);
  return frame;
}

}  // namespace rgbdcast::service
