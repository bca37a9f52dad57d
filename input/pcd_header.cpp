#include "input/pcd_header.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>
#include <set>
#include <sstream>
#include <vector>

namespace rgbdcast {

namespace {

Error bad_pcd(const std::string& what) { return make_error(ErrorCode::kInvalidInput, "PCD: " + what); }

// Whole-token unsigned integer in [lo, hi].
bool parse_count(const std::string& tok, long lo, long hi, long* out) {
  if (tok.empty() || tok.size() > 12 || tok.find_first_not_of("0123456789") != std::string::npos) return false;
  *out = std::stol(tok);
  return *out >= lo && *out <= hi;
}

// A whole token that strtod reads as a finite number.
bool finite_number(const std::string& tok) {
  if (tok.empty() || tok.size() > 64) return false;
  char* end = nullptr;
  const double v = std::strtod(tok.c_str(), &end);
  return end == tok.c_str() + tok.size() && std::isfinite(v);
}

std::uint32_t le32(const std::uint8_t* p) {
  return std::uint32_t(p[0]) | (std::uint32_t(p[1]) << 8) | (std::uint32_t(p[2]) << 16) | (std::uint32_t(p[3]) << 24);
}

}  // namespace

Result<PcdHeader> check_pcd_header(const std::uint8_t* data, size_t size) {
  constexpr size_t kMaxHeader = 64 * 1024;
  std::map<std::string, std::vector<std::string>> keys;
  size_t pos = 0;
  bool have_data = false;
  while (pos < size && pos < kMaxHeader && !have_data) {
    size_t end = pos;
    while (end < size && data[end] != '\n') ++end;
    std::string line(reinterpret_cast<const char*>(data + pos), end - pos);
    pos = end < size ? end + 1 : end;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (!line.empty() && line[0] == '#') continue;
    // PCL splits header lines its own way: a blank or space-led line is refused rather than interpreted twice.
    if (line.empty() || line[0] == ' ' || line[0] == '\t') return bad_pcd("blank or indented line in the header");
    std::istringstream ss(line);
    std::string key, tok;
    ss >> key;
    std::vector<std::string> values;
    while (ss >> tok && values.size() <= 1024) values.push_back(tok);
    if (values.size() > 1024) return bad_pcd("header line " + key + " has too many values");
    // Only the keys of the format: PCL matches keys by prefix and crashes on some it half-recognizes ("V\xf3RSION").
    static const std::set<std::string> kKeys = {"VERSION", "FIELDS", "SIZE",      "TYPE",   "COUNT",
                                                "WIDTH",   "HEIGHT", "VIEWPOINT", "POINTS", "DATA"};
    if (!kKeys.count(key)) {
      std::string shown = key.substr(0, 16);
      for (auto& c : shown)
        if (c < 0x20 || c > 0x7e) c = '?';  // one printable line, whatever the bytes
      return bad_pcd("unknown header line '" + shown + "'");
    }
    if (keys.count(key)) return bad_pcd("header key " + key + " appears twice");
    keys[key] = values;
    have_data = key == "DATA";
  }
  if (!have_data) return bad_pcd("no DATA line in the first 64 KiB");
  for (const char* k : {"FIELDS", "SIZE", "TYPE", "WIDTH", "HEIGHT"})
    if (!keys.count(k)) return bad_pcd(std::string("header has no ") + k);
  const auto& fields = keys["FIELDS"];
  const size_t n = fields.size();
  if (n == 0 || n > 64) return bad_pcd("1 to 64 FIELDS expected");
  const auto& sizes = keys["SIZE"];
  const auto& types = keys["TYPE"];
  std::vector<std::string> counts = keys.count("COUNT") ? keys["COUNT"] : std::vector<std::string>(n, "1");
  if (sizes.size() != n || types.size() != n || counts.size() != n)
    return bad_pcd("FIELDS, SIZE, TYPE and COUNT have different lengths");
  PcdHeader h;
  for (size_t i = 0; i < n; ++i) {
    long sz = 0, count = 0;
    if (!parse_count(sizes[i], 1, 8, &sz) || (sz != 1 && sz != 2 && sz != 4 && sz != 8))
      return bad_pcd("SIZE of " + fields[i] + " must be 1, 2, 4 or 8");
    if (types[i] != "I" && types[i] != "U" && types[i] != "F")
      return bad_pcd("TYPE of " + fields[i] + " must be I, U or F");
    if ((types[i] == "F" && sz != 4 && sz != 8)) return bad_pcd("a float field must be 4 or 8 bytes");
    if (!parse_count(counts[i], 1, 1024, &count)) return bad_pcd("COUNT of " + fields[i] + " must be 1..1024");
    h.point_bytes += static_cast<size_t>(sz * count);
  }
  if (h.point_bytes > 4096) return bad_pcd("points of more than 4 KiB");
  // The layout PCL maps onto PointXYZRGBA without surprises (fuzz_pcd found a use-after-free in PCL 1.13 on a
  // field list without x and a COUNT of 2): x, y, z as 4-byte floats, rgb or rgba as 4 bytes, each COUNT 1 and
  // named once; other fields COUNT 1, and "_" padding of any COUNT.
  std::set<std::string> seen;
  for (size_t i = 0; i < n; ++i) {
    const std::string& f = fields[i];
    if (f == "_") continue;
    if (!seen.insert(f).second) return bad_pcd("field " + f + " appears twice");
    if (counts[i] != "1") return bad_pcd("field " + f + " must have COUNT 1");
    if ((f == "x" || f == "y" || f == "z") && (types[i] != "F" || sizes[i] != "4"))
      return bad_pcd("field " + f + " must be a 4-byte float");
    if ((f == "rgb" || f == "rgba") && sizes[i] != "4") return bad_pcd("field " + f + " must be 4 bytes");
  }
  if (!seen.count("x") || !seen.count("y") || !seen.count("z")) return bad_pcd("fields x, y and z are required");
  if (!seen.count("rgb") && !seen.count("rgba")) return bad_pcd("a field rgb or rgba is required");
  long w = 0, ht = 0, points = 0;
  if (keys["WIDTH"].size() != 1 || !parse_count(keys["WIDTH"][0], 2, 8192, &w) || keys["HEIGHT"].size() != 1 ||
      !parse_count(keys["HEIGHT"][0], 2, 8192, &ht))
    return bad_pcd("WIDTH and HEIGHT must be 2..8192 (an organized frame)");
  h.width = static_cast<int>(w);
  h.height = static_cast<int>(ht);
  const size_t npoints = static_cast<size_t>(w) * static_cast<size_t>(ht);
  if (keys.count("POINTS") && (keys["POINTS"].size() != 1 || !parse_count(keys["POINTS"][0], 0, 1L << 40, &points) ||
                               static_cast<size_t>(points) != npoints))
    return bad_pcd("POINTS is not WIDTH x HEIGHT");
  if (keys.count("VERSION") && keys["VERSION"].size() != 1) return bad_pcd("VERSION takes one value");
  if (keys.count("VIEWPOINT")) {
    const auto& vp = keys["VIEWPOINT"];
    if (vp.size() != 7 || !std::all_of(vp.begin(), vp.end(), finite_number))
      return bad_pcd("VIEWPOINT must be 7 numbers (tx ty tz qw qx qy qz)");
  }
  if (keys["DATA"].size() != 1) return bad_pcd("DATA must be ascii, binary or binary_compressed");
  h.data = keys["DATA"][0];
  // PCL 1.13 keeps reading header lines after DATA (comments, blank lines and any line whose first token starts
  // with a key), so data that begins like "# ...\nFIELDS x" re-defines the fields and PCL overflows its buffer
  // (fuzz_pcd's fourth find). The same walk here: such data is refused.
  for (size_t at = pos; at < size;) {
    size_t end = at;
    while (end < size && data[end] != '\n') ++end;
    std::string line(reinterpret_cast<const char*>(data + at), std::min<size_t>(end - at, 64));
    at = end < size ? end + 1 : end;
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos) continue;
    if (line[first] == '#') continue;
    const std::string token = line.substr(first);
    bool key = false;
    for (const char* k :
         {"VERSION", "FIELDS", "COLUMNS", "SIZE", "TYPE", "COUNT", "WIDTH", "HEIGHT", "VIEWPOINT", "POINTS", "DATA"})
      key = key || token.rfind(k, 0) == 0;
    if (key) return bad_pcd("the data after DATA starts like a header line");
    break;
  }
  const size_t body = size - pos, need = npoints * h.point_bytes;
  if (h.data == "binary") {
    if (body < need)
      return bad_pcd("binary data holds " + std::to_string(body) + " bytes, the header needs " + std::to_string(need));
  } else if (h.data == "binary_compressed") {
    if (body < 8) return bad_pcd("binary_compressed data without its sizes");
    const size_t compressed = le32(data + pos), uncompressed = le32(data + pos + 4);
    if (compressed > body - 8) return bad_pcd("compressed data is cut short");
    if (uncompressed != need) return bad_pcd("uncompressed size is not POINTS x point size");
  } else if (h.data == "ascii") {
    size_t values = 0;
    for (size_t i = 0; i < n; ++i) values += static_cast<size_t>(std::stol(counts[i]));
    if (body / 2 < npoints * values) return bad_pcd("ascii data too short for WIDTH x HEIGHT points");
    // Every point on its own line with exactly one number per value (PCL 1.13 crashes on some malformed bodies,
    // found by fuzz_pcd); "nan" is a number here, as PCL writes it.
    size_t at = pos, lines = 0;
    while (at < size) {
      size_t end = at;
      while (end < size && data[end] != '\n') ++end;
      std::string line(reinterpret_cast<const char*>(data + at), end - at);
      at = end < size ? end + 1 : end;
      if (!line.empty() && line.back() == '\r') line.pop_back();
      if (line.empty() && at >= size) break;  // the final newline
      std::istringstream ss(line);
      std::string tok;
      size_t k = 0;
      while (ss >> tok) {
        if (!finite_number(tok) && tok != "nan" && tok != "NaN")
          return bad_pcd("ascii line " + std::to_string(lines + 1) + " holds something that is not a number");
        ++k;
      }
      if (k != values)
        return bad_pcd("ascii line " + std::to_string(lines + 1) + " holds " + std::to_string(k) + " values, not " +
                       std::to_string(values));
      if (++lines > npoints) return bad_pcd("ascii data holds more than WIDTH x HEIGHT points");
    }
    if (lines != npoints) return bad_pcd("ascii data holds " + std::to_string(lines) + " points, not WIDTH x HEIGHT");
  } else {
    return bad_pcd("DATA must be ascii, binary or binary_compressed");
  }
  return h;
}

}  // namespace rgbdcast
