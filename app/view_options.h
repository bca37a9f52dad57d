#pragma once
// Command-line options shared by render and eval: backend, mode, point size, image size, camera.
#include <CLI/CLI.hpp>
#include <string>

#include "renderer/create_renderer.h"
#include "scene/scene.h"

namespace rgbdcast::app {

struct ViewArgs {
  std::string backend = "auto";
  std::string mode = "mesh";
  float point_size_px = 1.0f;
  int width = 0, height = 0;  // 0 = the capture camera's size
  std::string pose;           // "capture" or empty
  std::string eye, target, up = "0,-1,0";
  double fov_deg = 60.0;
};

void add_backend_options(CLI::App* cmd, ViewArgs* args);
void add_camera_options(CLI::App* cmd, ViewArgs* args);
Result<RenderOptions> render_options(const ViewArgs& args);
// The camera the options describe, for a scene (its first capture camera for --pose capture).
Result<ViewCamera> view_camera(const ViewArgs& args, const Scene& scene);
// Creates the renderer the --backend option names; the selection carries the reason for the choice.
Result<RendererSelection> make_renderer(const ViewArgs& args);
// Writes an RGBA image as PNG (or JPEG by extension) atomically.
Status write_image(const Image& image, const std::string& path);

}  // namespace rgbdcast::app
