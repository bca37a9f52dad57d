// rgbdcast: reduce RGB-D views to small textured meshes, render them headless, serve them to operators.
#include <CLI/CLI.hpp>
#include <iostream>

#include "app/commands.h"

int main(int argc, char** argv) {
  CLI::App app{"rgbdcast: efficient transmission and rendering of RGB-D views"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "rgbdcast 0.1.0");
  rgbdcast::app::register_reduce(app);
  rgbdcast::app::register_render(app);
  rgbdcast::app::register_eval(app);
  rgbdcast::app::register_eval_trajectory(app);
  rgbdcast::app::register_serve(app);
  rgbdcast::app::register_convert(app);
  rgbdcast::app::register_stream(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  return 0;
}
