#pragma once
// One way for every subcommand to fail: one line on stderr, exit code 2 for bad input or arguments, 1 otherwise.
#include <CLI/CLI.hpp>
#include <iostream>
#include <string>

#include "scene/result.h"

namespace rgbdcast::app {

[[noreturn]] inline void fail(const std::string& command, const Error& e) {
  std::cerr << "rgbdcast " << command << ": error: " << e.message << "\n";
  const bool bad_input = e.code == ErrorCode::kInvalidInput || e.code == ErrorCode::kInvalidArgument ||
                         e.code == ErrorCode::kNotFound || e.code == ErrorCode::kEmpty;
  throw CLI::RuntimeError(bad_input ? 2 : 1);
}

}  // namespace rgbdcast::app
