#include "tests/common/gltf_validator.h"

#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "tests/common/test_data.h"

namespace rgbdcast::test {

ValidatorReport validate_gltf_file(const std::string& path) {
  namespace fs = std::filesystem;
  ValidatorReport r;
  const std::string script = source_path("tools/validate_gltf.mjs");
  if (!fs::exists(source_path("tools/node_modules/gltf-validator/package.json"))) {
    r.why_not = "tools/node_modules/gltf-validator missing (run scripts/setup.sh)";
    return r;
  }
  if (std::system("node --version > /dev/null 2>&1") != 0) {
    r.why_not = "node is not installed";
    return r;
  }
  const std::string cmd = "node '" + script + "' '" + path + "' 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) {
    r.why_not = "cannot run node";
    return r;
  }
  std::string out;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
  const int rc = pclose(p);
  const auto j = nlohmann::json::parse(out, nullptr, false);
  if (rc != 0 || j.is_discarded() || !j.contains("issues")) {
    r.ran = true;  // the validator ran and failed: that is a test failure, not a skip
    r.errors = 1;
    r.warnings = 0;
    r.messages = "validator failed: " + out.substr(0, 2000);
    return r;
  }
  r.ran = true;
  const auto& is = j["issues"];
  r.errors = is.value("numErrors", -1);
  r.warnings = is.value("numWarnings", -1);
  r.infos = is.value("numInfos", -1);
  for (const auto& m : is.value("messages", nlohmann::json::array()))
    if (m.value("severity", 3) <= 1)
      r.messages += m.value("code", std::string()) + ": " + m.value("message", std::string()) + " @ " +
                    m.value("pointer", std::string()) + "\n";
  return r;
}

}  // namespace rgbdcast::test
