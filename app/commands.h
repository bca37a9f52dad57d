#pragma once
// Each subcommand of the rgbdcast CLI lives in its own file (app/cmd_<name>.cpp) and registers itself here.
#include <CLI/CLI.hpp>

namespace rgbdcast::app {

void register_reduce(CLI::App& app);
void register_render(CLI::App& app);
void register_eval(CLI::App& app);
void register_eval_trajectory(CLI::App& app);
void register_serve(CLI::App& app);

}  // namespace rgbdcast::app

// Conventions for every command: a failure prints one line "rgbdcast <cmd>: error: <message>" to stderr and
// ends with throw CLI::RuntimeError(exit_code) from the callback (2 for bad arguments or input, 1 otherwise).
// Files are written to a temporary name and renamed, so a failure leaves nothing behind.
