// rgbdcast reduce: one RGB-D frame -> a small textured mesh in a GLB, with a per-stage report.
#include <chrono>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "app/cli_error.h"
#include "app/commands.h"
#include "app/report.h"
#include "gltf/gltf_io.h"
#include "input/frame_source.h"
#include "reduction/pipeline.h"

namespace rgbdcast::app {

namespace {

struct ReduceArgs {
  std::string input, depth, intrinsics, associations, out, report;
  int frame = 0;
  double depth_scale = 0;
  ReductionParams params;
};

[[noreturn]] void fail(const Error& e) { app::fail("reduce", e); }

nlohmann::json intrinsics_json(const Intrinsics& k) {
  return {{"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx}, {"cy", k.cy}, {"width", k.width}, {"height", k.height}};
}

void run_reduce(const ReduceArgs& a) {
  using clock = std::chrono::steady_clock;
  const auto t0 = clock::now();
  if (a.frame < 0) fail(make_error(ErrorCode::kInvalidArgument, "--frame must be 0 or more"));
  SourceOptions so;
  so.intrinsics = a.intrinsics;
  so.depth_path = a.depth;
  so.associations_path = a.associations;
  if (a.depth_scale != 0) so.depth_scale = a.depth_scale;
  auto source = open_frame_source(a.input, so);
  if (!source) fail(source.error());
  auto frame = (*source)->frame(static_cast<size_t>(a.frame));
  if (!frame) fail(frame.error());
  const double load_ms = std::chrono::duration<double, std::milli>(clock::now() - t0).count();

  auto reduced = reduce_frame(*frame, a.params);
  if (!reduced) fail(reduced.error());

  Scene scene;
  CaptureCamera cam;
  cam.intrinsics = frame->intrinsics;
  cam.timestamp = frame->timestamp;
  cam.source = frame->color_path;
  cam.frame_index = frame->index;
  scene.cameras.push_back(cam);
  SceneNode node;
  node.name = "frame_" + std::to_string(frame->index);
  node.mesh = std::move(reduced->mesh);
  scene.nodes.push_back(std::move(node));
  std::vector<StageReport> stages = reduced->stages;

  nlohmann::json extras = {{"rgbdcast", {{"source", frame->color_path},
                                         {"depth", frame->depth_path},
                                         {"frame", frame->index},
                                         {"timestamp", frame->timestamp},
                                         {"intrinsics", intrinsics_json(frame->intrinsics)},
                                         {"stages", stages_json(stages)}}}};
  scene.extras_json = extras.dump();

  const auto te = clock::now();
  auto glb = encode_glb(scene);
  if (!glb) fail(glb.error());
  stages.push_back({"export", "bytes", glb->size(), std::chrono::duration<double, std::milli>(clock::now() - te).count()});

  // Write atomically: temp file then rename, so a failure leaves nothing behind.
  const std::string tmp = a.out + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(glb->data()), static_cast<std::streamsize>(glb->size()));
    if (!out) {
      std::filesystem::remove(tmp);
      fail(make_error(ErrorCode::kIo, "cannot write " + a.out));
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, a.out, ec);
  if (ec) {
    std::filesystem::remove(tmp);
    fail(make_error(ErrorCode::kIo, "cannot write " + a.out + ": " + ec.message()));
  }
  const double total_ms = std::chrono::duration<double, std::milli>(clock::now() - t0).count();

  const Mesh& mesh = scene.nodes[0].mesh;
  std::cout << "rgbdcast reduce: " << frame->color_path << " (frame " << frame->index << ", "
            << frame->intrinsics.width << "x" << frame->intrinsics.height << ")\n"
            << stages_table(stages) << "points " << mesh.positions.size() << ", triangles " << mesh.triangle_count()
            << ", " << glb->size() << " bytes -> " << a.out << " (load " << static_cast<int>(load_ms) << " ms, total "
            << static_cast<int>(total_ms) << " ms)\n";
  if (!a.report.empty()) {
    nlohmann::json r = {{"input", a.input},
                        {"frame", frame->index},
                        {"timestamp", frame->timestamp},
                        {"intrinsics", intrinsics_json(frame->intrinsics)},
                        {"params",
                         {{"outliers", a.params.outlier_method == OutlierMethod::kKdTree ? "kdtree" : "organized"},
                          {"outlier_k", a.params.outlier_k},
                          {"outlier_std_mul", a.params.outlier_std_mul},
                          {"voxel_size_m", a.params.voxel_size_m},
                          {"max_edge_m", a.params.max_edge_m},
                          {"perimeter_factor", a.params.perimeter_factor}}},
                        {"stages", stages_json(stages)},
                        {"points", mesh.positions.size()},
                        {"triangles", mesh.triangle_count()},
                        {"bytes", glb->size()},
                        {"load_ms", load_ms},
                        {"total_ms", total_ms},
                        {"out", a.out}};
    if (auto st = write_text_file_atomic(a.report, r.dump(2) + "\n"); !st) fail(st.error());
  }
}

}  // namespace

void register_reduce(CLI::App& app) {
  auto args = std::make_shared<ReduceArgs>();
  CLI::App* cmd = app.add_subcommand("reduce", "Reduce an RGB-D frame to a small textured mesh (GLB)");
  cmd->add_option("--input", args->input,
                  "TUM folder, color/+depth/ folder, colour image (with --depth) or organized .pcd")->required();
  cmd->add_option("--frame", args->frame, "Frame index (N-th associated rgb/depth pair)");
  cmd->add_option("--depth", args->depth, "Depth PNG for a single colour image");
  cmd->add_option("--intrinsics", args->intrinsics, "fr1|fr2|fr3|kinect|icl or a JSON file (default: guessed)");
  cmd->add_option("--depth-scale", args->depth_scale, "Raw depth units per metre (TUM 5000, mm sensors 1000)");
  cmd->add_option("--associations", args->associations, "TUM associations file (t_rgb rgb t_depth depth)");
  cmd->add_option("--outliers", args->params.outlier_method,
                  "Outlier neighbour search: kdtree (PCL, the paper's) or organized (image window, faster)")
      ->transform(CLI::CheckedTransformer(std::map<std::string, OutlierMethod>{
          {"kdtree", OutlierMethod::kKdTree}, {"organized", OutlierMethod::kOrganized}}))
      ->capture_default_str();
  cmd->add_option("--outlier-k", args->params.outlier_k, "Statistical outlier removal: neighbours K")->capture_default_str();
  cmd->add_option("--outlier-std", args->params.outlier_std_mul, "Statistical outlier removal: std-dev multiplier T")
      ->capture_default_str();
  cmd->add_option("--voxel-size", args->params.voxel_size_m, "Voxel grid edge in metres")->capture_default_str();
  cmd->add_option("--max-edge", args->params.max_edge_m, "Greedy triangulation max edge length d in metres")
      ->capture_default_str();
  cmd->add_option("--mu", args->params.mu, "Greedy triangulation neighbour distance multiplier")->capture_default_str();
  cmd->add_option("--max-neighbours", args->params.max_neighbours, "Greedy triangulation nearest neighbours")
      ->capture_default_str();
  cmd->add_option("--perimeter-factor", args->params.perimeter_factor, "Drop triangles with perimeter > factor*d")
      ->capture_default_str();
  cmd->add_option("--out", args->out, "Output GLB")->required();
  cmd->add_option("--report", args->report, "Write the JSON report here");
  cmd->callback([args] { run_reduce(*args); });
}

}  // namespace rgbdcast::app
