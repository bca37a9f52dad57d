#include "app/report.h"

#include <cstdio>

#include "base/atomic_file.h"

namespace rgbdcast::app {

nlohmann::json stages_json(const std::vector<StageReport>& stages) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& s : stages) out.push_back({{"name", s.name}, {s.unit, s.count}, {"ms", s.ms}});
  return out;
}

std::string stages_table(const std::vector<StageReport>& stages) {
  std::string out;
  char line[160];
  std::snprintf(line, sizeof line, "%-12s %12s %-10s %10s\n", "stage", "count", "unit", "ms");
  out += line;
  double total = 0;
  for (const auto& s : stages) {
    std::snprintf(line, sizeof line, "%-12s %12zu %-10s %10.1f\n", s.name.c_str(), s.count, s.unit.c_str(), s.ms);
    out += line;
    total += s.ms;
  }
  std::snprintf(line, sizeof line, "%-12s %12s %-10s %10.1f\n", "total", "", "", total);
  out += line;
  return out;
}

Status write_text_file_atomic(const std::string& path, const std::string& text) {
  return write_file_atomically(path, std::vector<std::uint8_t>(text.begin(), text.end()));
}

}  // namespace rgbdcast::app
