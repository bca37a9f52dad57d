// rgbdcast render: a view of a GLB scene from the capture pose, any look-at camera or a full camera (--camera JSON),
// on a software GPU.
#include <fstream>
#include <iostream>
#include <sstream>
#include <nlohmann/json.hpp>

#include "app/cli_error.h"
#include "app/commands.h"
#include "app/report.h"
#include "app/view_options.h"
#include "gltf/gltf_io.h"
#include "service/camera_json.h"

namespace rgbdcast::app {

namespace {

struct RenderArgs {
  std::string scene, out, report;
  std::string camera;  // a camera JSON file (service/camera_json.h)
  ViewArgs view;
};

// The camera of --camera FILE, which replaces the pose and size options.
Result<ViewCamera> camera_from_file(const RenderArgs& a) {
  if (!a.view.pose.empty() || !a.view.eye.empty() || !a.view.target.empty() || a.view.width || a.view.height)
    return make_error(ErrorCode::kInvalidArgument, "--camera excludes --pose, --eye, --target, --width and --height");
  std::ifstream in(a.camera, std::ios::binary);
  if (!in) return make_error(ErrorCode::kNotFound, "cannot open " + a.camera);
  std::ostringstream text;
  text << in.rdbuf();
  auto camera = service::parse_camera_json(text.str(), kMaxImageSize);
  if (!camera) return make_error(camera.error().code, a.camera + ": " + camera.error().message);
  return camera;
}

void run_render(const RenderArgs& a) {
  auto fail = [](const Error& e) { app::fail("render", e); };
  auto options = render_options(a.view);
  if (!options) fail(options.error());
  auto scene = read_glb_file(a.scene);
  if (!scene) fail(scene.error());
  auto camera = a.camera.empty() ? view_camera(a.view, *scene) : camera_from_file(a);
  if (!camera) fail(camera.error());
  auto selection = make_renderer(a.view);
  if (!selection) fail(selection.error());
  Renderer& renderer = *selection->renderer;
  double upload_ms = 0;
  auto id = renderer.upload(*scene, &upload_ms);
  if (!id) fail(id.error());
  auto result = renderer.render(*id, *camera, *options);
  if (!result) fail(result.error());
  if (auto st = write_image(result->color, a.out); !st) fail(st.error());
  std::cout << "rgbdcast render: " << renderer.backend() << " on " << renderer.device() << " (" << selection->reason
            << "), " << result->color.width << "x" << result->color.height << " " << a.view.mode << ": upload "
            << upload_ms << " ms, render " << result->timings.render_ms << " ms, readback "
            << result->timings.readback_ms << " ms -> " << a.out << "\n";
  if (!a.report.empty()) {
    nlohmann::json r = {{"backend", renderer.backend()},
                        {"device", renderer.device()},
                        {"reason", selection->reason},
                        {"mode", a.view.mode},
                        {"width", result->color.width},
                        {"height", result->color.height},
                        {"upload_ms", upload_ms},
                        {"render_ms", result->timings.render_ms},
                        {"readback_ms", result->timings.readback_ms},
                        {"out", a.out}};
    if (auto st = write_text_file_atomic(a.report, r.dump(2) + "\n"); !st) fail(st.error());
  }
}

}  // namespace

void register_render(CLI::App& app) {
  auto args = std::make_shared<RenderArgs>();
  CLI::App* cmd = app.add_subcommand("render", "Render a view of a GLB scene headless (Vulkan/lavapipe or OSMesa)");
  cmd->add_option("--scene", args->scene, "GLB scene")->required();
  add_camera_options(cmd, &args->view);
  cmd->add_option("--camera", args->camera,
                  "Camera JSON {fx,fy,cx,cy,width,height,pose}: pose a row-major 4x4 camera-to-world matrix in the "
                  "scene's world frame (x right, y down, z forward)");
  add_backend_options(cmd, &args->view);
  cmd->add_option("--out", args->out, "Output image (.png or .jpg)")->required();
  cmd->add_option("--report", args->report, "Write timings as JSON here");
  cmd->callback([args] { run_render(*args); });
}

}  // namespace rgbdcast::app
