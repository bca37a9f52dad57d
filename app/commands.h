#pragma once
// Each subcommand of the rgbdcast CLI lives in its own file (app/cmd_<name>.cpp) and registers itself here.
#include <CLI/CLI.hpp>
#include <string>

#include "gltf/gltf_io.h"

namespace rgbdcast::app {

void register_reduce(CLI::App& app);
void register_render(CLI::App& app);
void register_eval(CLI::App& app);
void register_eval_trajectory(CLI::App& app);
void register_serve(CLI::App& app);
void register_convert(CLI::App& app);
void register_stream(CLI::App& app);

// --flavor compact|compat into glb->flavor (app/cmd_convert.cpp); an unknown name is a one-line error, exit 2.
// default_name is what the help shows; the caller's glb->flavor holds the default itself.
void add_flavor_option(CLI::App* cmd, GlbWriteOptions* glb, const std::string& default_name);
// --geometry-codec meshopt|draco into glb->geometry_codec (compact flavour); an unknown name is one line, exit 2.
// `chosen` (optional) is set when the option is given, for commands whose default depends on other options.
void add_geometry_codec_option(CLI::App* cmd, GlbWriteOptions* glb, bool* chosen = nullptr);

}  // namespace rgbdcast::app

// Conventions for every command: a failure prints one line "rgbdcast <cmd>: error: <message>" to stderr and
// ends with throw CLI::RuntimeError(exit_code) from the callback (2 for bad arguments or input, 1 otherwise).
// Files are written to a temporary name and renamed, so a failure leaves nothing behind.
