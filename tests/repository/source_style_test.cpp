// The C++ sources follow the repository's .clang-format, as clang-format 14 (Debian 12's) writes them: the style is
// a rule the test command checks, not a habit. Reformat with
//   git ls-files -z '*.cpp' '*.h' | xargs -0 clang-format-14 -i
#include <gtest/gtest.h>

#include <sstream>
#include <string>
#include <vector>

#include "tests/common/run_command.h"
#include "tests/common/test_data.h"

namespace rgbdcast {
namespace {

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) out.push_back(line);
  return out;
}

TEST(SourceStyle, EveryCppSourceIsClangFormatted) {
  if (test::run_command("command -v clang-format-14 && command -v git").exit_code != 0)
    RGBDCAST_MISSING_PREREQUISITE("clang-format-14 or git not found (scripts/setup.sh test installs them)");
  const std::string root = test::source_path("");
  const auto listed = test::run_command("git -C '" + root + "' ls-files '*.cpp' '*.h'");
  if (listed.exit_code != 0) RGBDCAST_MISSING_PREREQUISITE("not a git checkout: " + root);
  const auto files = lines(listed.out);
  ASSERT_GT(files.size(), 100u) << "git ls-files listed too few sources in " << root;

  // --dry-run -Werror prints one "file:line:col: error: code should be clang-formatted" per place and fails.
  const auto checked = test::run_command("cd '" + root + "' && git ls-files -z '*.cpp' '*.h' | " +
                                         "xargs -0 clang-format-14 --dry-run -Werror 2>&1");
  std::vector<std::string> places;
  for (const auto& line : lines(checked.out))
    if (line.find(": error:") != std::string::npos) places.push_back(line.substr(0, line.find(": error:")));
  EXPECT_EQ(checked.exit_code, 0) << places.size() << " places are not formatted, first: "
                                  << (places.empty() ? checked.out.substr(0, 400) : places.front());
}

}  // namespace
}  // namespace rgbdcast
