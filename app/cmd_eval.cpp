// rgbdcast eval: how faithful is a reduced scene? Renders it at the capture pose and compares with the real colour
// image over the pixels that had valid depth (PSNR, SSIM, coverage).
#include <iostream>
#include <optional>
#include <nlohmann/json.hpp>

#include "app/cli_error.h"
#include "app/commands.h"
#include "app/view_options.h"
#include "evaluation/image_metrics.h"
#include "gltf/gltf_io.h"
#include "input/frame_source.h"
#include "keyframes/trajectory_io.h"
#include "reduction/pipeline.h"

namespace rgbdcast::app {

namespace {

struct EvalArgs {
  std::string input, depth, intrinsics, scene, save_render, groundtruth;
  int frame = 0;
  int scene_frame = -1;  // novel views: the frame the scene was reduced from
  bool full_cloud = false;
  ViewArgs view;
};

void run_eval(const EvalArgs& a) {
  auto fail = [](const Error& e) { app::fail("eval", e); };
  if (a.scene.empty() == !a.full_cloud)
    fail(make_error(ErrorCode::kInvalidArgument, "give --scene S.glb or --full-cloud"));
  auto options = render_options(a.view);
  if (!options) fail(options.error());
  SourceOptions so;
  so.intrinsics = a.intrinsics;
  so.depth_path = a.depth;
  auto source = open_frame_source(a.input, so);
  if (!source) fail(source.error());
  if (a.frame < 0) fail(make_error(ErrorCode::kInvalidArgument, "--frame must be 0 or more"));
  auto frame = (*source)->frame(static_cast<size_t>(a.frame));
  if (!frame) fail(frame.error());

  // Novel view (--groundtruth): the scene lives in the camera frame of frame --scene-frame, and we look from where
  // frame --frame really was. The full cloud is then frame scene_frame's own, never frame N's: frame N's cloud seen
  // from the relative pose I->N would be a wrong picture of the wrong frame (about 9 dB on fr1/xyz).
  std::optional<RgbdFrame> scene_source;
  if (!a.groundtruth.empty()) {
    if (a.scene_frame < 0) fail(make_error(ErrorCode::kInvalidArgument, "--groundtruth needs --scene-frame"));
    auto f = (*source)->frame(static_cast<size_t>(a.scene_frame));
    if (!f) fail(f.error());
    scene_source = std::move(*f);
  }

  Scene scene;
  if (a.full_cloud) {
    // The paper's baseline: every valid pixel of the scene's frame as a point.
    const RgbdFrame& cloud_frame = scene_source ? *scene_source : *frame;
    SceneNode node;
    node.name = "full_cloud";
    node.points = full_cloud(cloud_frame);
    scene.nodes.push_back(std::move(node));
    CaptureCamera cam;
    cam.intrinsics = cloud_frame.intrinsics;
    scene.cameras.push_back(cam);
  } else {
    auto loaded = read_glb_file(a.scene);
    if (!loaded) fail(loaded.error());
    scene = std::move(*loaded);
    if (scene.cameras.empty())
      fail(make_error(ErrorCode::kInvalidInput, a.scene + ": no capture camera to evaluate at"));
  }
  const Intrinsics& k = frame->intrinsics;
  CaptureCamera at = scene.cameras.front();
  at.intrinsics = k;  // the frame's own camera, at the scene's capture pose
  if (scene_source) {
    auto gt = read_trajectory(a.groundtruth);
    if (!gt) fail(gt.error());
    auto find = [&](const RgbdFrame& f) -> const StampedPose* {
      if (const StampedPose* p = pose_with_index(*gt, f.index)) return p;
      return nearest_pose(*gt, f.timestamp, 0.02);
    };
    const StampedPose* from = find(*scene_source);
    const StampedPose* to = find(*frame);
    if (!from || !to)
      fail(make_error(ErrorCode::kNotFound,
                      "no ground-truth pose for frame " + std::to_string(from ? frame->index : scene_source->index)));
    at.camera_to_world = from->camera_to_world.inverse() * to->camera_to_world;
  }
  const ViewCamera camera = ViewCamera::from_capture(at);

  auto selection = make_renderer(a.view);
  if (!selection) fail(selection.error());
  auto id = selection->renderer->upload(scene);
  if (!id) fail(id.error());
  auto rendered = selection->renderer->render(*id, camera, *options);
  if (!rendered) fail(rendered.error());
  if (!a.save_render.empty())
    if (auto st = write_image(rendered->color, a.save_render); !st) fail(st.error());
  cv::Mat valid = frame->depth_m > 0;
  auto fidelity = compare_views(frame->color_rgb, rendered->color, valid);
  if (!fidelity) fail(fidelity.error());
  nlohmann::json out = {{"psnr_db", fidelity->psnr_db},
                        {"ssim", fidelity->ssim},
                        {"coverage", fidelity->coverage},
                        {"psnr_valid_db", fidelity->psnr_valid_db},
                        {"ssim_valid", fidelity->ssim_valid},
                        {"valid_pixels", fidelity->valid_pixels},
                        {"covered_pixels", fidelity->covered_pixels},
                        {"mode", a.view.mode},
                        {"source", a.full_cloud ? std::string("full_cloud") : a.scene},
                        {"backend", selection->renderer->backend()},
                        {"render_ms", rendered->timings.render_ms},
                        {"frame", frame->index},
                        {"scene_frame", a.groundtruth.empty() ? frame->index : a.scene_frame}};
  std::cout << out.dump(2) << "\n";
}

}  // namespace

void register_eval(CLI::App& app) {
  auto args = std::make_shared<EvalArgs>();
  CLI::App* cmd = app.add_subcommand("eval", "Render a scene at the capture pose and compare with the real frame");
  cmd->add_option("--input", args->input, "The frame's source, as for reduce")->required();
  cmd->add_option("--frame", args->frame, "Frame index");
  cmd->add_option("--depth", args->depth, "Depth PNG for a single colour image");
  cmd->add_option("--intrinsics", args->intrinsics, "fr1|fr2|fr3|kinect|icl or a JSON file");
  cmd->add_option("--scene", args->scene, "GLB scene reduced from that frame");
  cmd->add_flag(
      "--full-cloud", args->full_cloud,
      "Evaluate a full cloud as splats instead of a scene: --scene-frame's with --groundtruth, else --frame's");
  cmd->add_option("--groundtruth", args->groundtruth,
                  "Novel view: render at --frame's true pose from this trajectory (TUM, .log, pose.txt)");
  cmd->add_option("--scene-frame", args->scene_frame, "Novel view: the frame the scene was reduced from");
  add_backend_options(cmd, &args->view);
  cmd->add_option("--save-render", args->save_render, "Also write the rendered view here");
  cmd->callback([args] { run_eval(*args); });
}

}  // namespace rgbdcast::app
