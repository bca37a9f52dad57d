#pragma once
// Runs a shell command for a test and captures its exit code, stdout and stderr.
#include <string>

namespace rgbdcast::test {

struct CommandResult {
  int exit_code = -1;
  std::string out, err;
};

CommandResult run_command(const std::string& command);
// The rgbdcast binary of this build.
std::string rgbdcast_binary();

}  // namespace rgbdcast::test
