// docs/cli.md against the binary: every subcommand `rgbdcast --help` lists has a section "## `rgbdcast NAME`", and
// each section names exactly the options that `rgbdcast NAME --help` prints, so the reference cannot drift from the
// code. The options are the `--long-name` tokens of each; prose in a section may only name its own command's.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>

#include "tests/common/run_command.h"
#include "tests/common/test_data.h"

namespace rgbdcast {
namespace {

std::set<std::string> long_options(const std::string& text) {
  static const std::regex option(R"((^|[^A-Za-z0-9_-])(--[a-z0-9][a-z0-9-]*))");
  std::set<std::string> out;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), option); it != std::sregex_iterator(); ++it)
    out.insert((*it)[2].str());
  out.erase("--help");
  return out;
}

// The subcommands of `rgbdcast --help`: the first word of each line under "Subcommands:".
std::set<std::string> subcommands(const std::string& help) {
  std::set<std::string> out;
  std::istringstream in(help);
  std::string line;
  bool listing = false;
  while (std::getline(in, line)) {
    if (line.rfind("Subcommands:", 0) == 0 || line.rfind("SUBCOMMANDS:", 0) == 0) {
      listing = true;
      continue;
    }
    if (!listing) continue;
    std::istringstream words(line);
    std::string name;
    if (words >> name) out.insert(name);
  }
  return out;
}

// docs/cli.md's sections "## `rgbdcast NAME`", each up to the next "## ".
std::map<std::string, std::string> doc_sections(const std::string& doc) {
  std::map<std::string, std::string> out;
  std::istringstream in(doc);
  std::string line, current;
  static const std::regex heading(R"(^## `rgbdcast ([a-z-]+)`)");
  while (std::getline(in, line)) {
    std::smatch m;
    if (std::regex_search(line, m, heading)) {
      current = m[1];
      out[current];
    } else if (line.rfind("## ", 0) == 0) {
      current.clear();
    } else if (!current.empty()) {
      out[current] += line + "\n";
    }
  }
  return out;
}

std::string joined(const std::set<std::string>& s) {
  std::string out;
  for (const auto& x : s) out += (out.empty() ? "" : " ") + x;
  return out;
}

TEST(CliReference, DocsCliMdNamesExactlyTheOptionsOfEachSubcommand) {
  std::ifstream in(test::source_path("docs/cli.md"));
  ASSERT_TRUE(in) << "docs/cli.md is missing";
  const std::string doc((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto sections = doc_sections(doc);

  const auto top = test::run_command(test::rgbdcast_binary() + " --help");
  ASSERT_EQ(top.exit_code, 0) << top.err;
  const auto commands = subcommands(top.out);
  ASSERT_GE(commands.size(), 5u) << top.out;
  for (const auto& [name, text] : sections)
    EXPECT_TRUE(commands.count(name)) << "docs/cli.md documents `rgbdcast " << name << "`, which the binary lacks";

  for (const auto& name : commands) {
    SCOPED_TRACE("rgbdcast " + name);
    const auto help = test::run_command(test::rgbdcast_binary() + " " + name + " --help");
    ASSERT_EQ(help.exit_code, 0) << help.err;
    const std::set<std::string> in_binary = long_options(help.out);
    EXPECT_FALSE(in_binary.empty()) << help.out;
    auto section = sections.find(name);
    ASSERT_NE(section, sections.end()) << "docs/cli.md has no section \"## `rgbdcast " << name << "`\"";
    const std::set<std::string> in_doc = long_options(section->second);
    std::set<std::string> missing, stale;
    for (const auto& o : in_binary)
      if (!in_doc.count(o)) missing.insert(o);
    for (const auto& o : in_doc)
      if (!in_binary.count(o)) stale.insert(o);
    EXPECT_TRUE(missing.empty()) << "options of `rgbdcast " << name
                                 << " --help` not in docs/cli.md: " << joined(missing);
    EXPECT_TRUE(stale.empty()) << "options in docs/cli.md that `rgbdcast " << name
                               << "` does not have: " << joined(stale);
  }
}

}  // namespace
}  // namespace rgbdcast
