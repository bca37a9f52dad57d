#pragma once
// The reduce report: stage counts and times as JSON (--report) and as a table on stdout.
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "reduction/pipeline.h"
#include "scene/result.h"

namespace rgbdcast::app {

nlohmann::json stages_json(const std::vector<StageReport>& stages);
std::string stages_table(const std::vector<StageReport>& stages);
// Writes text atomically (temp file + rename).
Status write_text_file_atomic(const std::string& path, const std::string& text);

}  // namespace rgbdcast::app
