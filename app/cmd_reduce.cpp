// rgbdcast reduce: RGB-D frames -> a small textured mesh in a GLB, with a per-stage report. One frame, or with
// --sequence the keyframes of a sequence placed in one world frame.
#include <chrono>
#include <iostream>
#include <nlohmann/json.hpp>

#include "app/cli_error.h"
#include "app/commands.h"
#include "app/reduce_common.h"
#include "app/reduce_sequence.h"
#include "app/report.h"
#include "base/atomic_file.h"
#include "base/malloc_settings.h"
#include "base/stopwatch.h"
#include "input/frame_source.h"
#include "pipeline/keyframe_glb.h"

namespace rgbdcast::app {

namespace {

[[noreturn]] void fail(const Error& e) { app::fail("reduce", e); }

nlohmann::json export_json(const GlbStats& s) {
  return {{"name", "export"},
          {"bytes", s.total_bytes},
          {"geometry_bytes", s.geometry_bytes},
          {"texture_bytes", s.texture_bytes},
          {"json_bytes", s.json_bytes},
          {"ms", s.ms}};
}

void run_single(const ReduceArgs& a, const FrameSource& source) {
  using clock = std::chrono::steady_clock;
  const auto t0 = clock::now();
  if (a.frame < 0) fail(make_error(ErrorCode::kInvalidArgument, "--frame must be 0 or more"));
  auto frame = source.frame(static_cast<size_t>(a.frame));
  if (!frame) fail(frame.error());
  const double load_ms = ms_since(t0);

  auto options = frame_options(a);
  if (!options) fail(options.error());
  auto textured = reduce_and_texture(*frame, *options);
  if (!textured) fail(textured.error());
  std::vector<StageReport> stages = textured->stages;
  const AtlasResult atlas_stats = textured->atlas_stats;
  const nlohmann::json choices = reduction_choices(*textured);
  const BudgetChoice budget = textured->budget;
  const Mesh& reduced = textured->node.mesh;
  const size_t points = reduced.positions.size(), triangles = reduced.triangle_count();
  const int texture_width = reduced.texture.width, texture_height = reduced.texture.height;
  const nlohmann::json capture = {{"source", frame->color_path},
                                  {"depth", frame->depth_path},
                                  {"frame", frame->index},
                                  {"timestamp", frame->timestamp},
                                  {"intrinsics", intrinsics_json(frame->intrinsics)},
                                  {"stages", stages_json(stages)}};

  GlbStats glb_stats;
  auto glb = encode_keyframe_glb(std::move(*textured), capture, options->glb, &glb_stats);
  if (!glb) fail(glb.error());
  stages.push_back({"export", "bytes", glb->size(), glb_stats.ms});
  if (auto st = write_file_atomically(a.out, *glb); !st) fail(st.error());
  const double total_ms = ms_since(t0);

  std::cout << "rgbdcast reduce: " << frame->color_path << " (frame " << frame->index << ", " << frame->intrinsics.width
            << "x" << frame->intrinsics.height << ")\n"
            << stages_table(stages) << "points " << points << ", triangles " << triangles << ", texture "
            << to_string(atlas_stats.mode) << " " << texture_width << "x" << texture_height << ", " << glb->size()
            << " bytes (geometry " << glb_stats.geometry_bytes << ", texture " << glb_stats.texture_bytes << ") -> "
            << a.out << " (load " << static_cast<int>(load_ms) << " ms, total " << static_cast<int>(total_ms)
            << " ms)\n";
  if (budget.budget_bytes > 0)
    std::cout << "budget " << budget.budget_bytes / 1000 << " kB (" << budget.rule << "): tolerance "
              << budget.tolerance_factor << " sigma, collapses " << budget.simplify_px << " px, JPEG q"
              << budget.jpeg_quality << " at scale " << budget.texture_scale << "\n";
  if (a.report.empty()) return;
  nlohmann::json stage_list = stages_json(stages);
  // The atlas and export stages carry their details.
  for (auto& s : stage_list) {
    if (s["name"] == "atlas") {
      const AtlasResult& at = atlas_stats;
      s["mode"] = to_string(at.mode);
      s["width"] = at.width;
      s["height"] = at.height;
      s["cells"] = at.cells;
      s["triangles"] = at.triangles;
      s["build_ms"] = at.ms;
      s["encode_ms"] = at.encode_ms;
    }
    if (s["name"] == "export") s = export_json(glb_stats);
  }
  nlohmann::json r = {{"input", a.input},
                      {"frame", frame->index},
                      {"timestamp", frame->timestamp},
                      {"intrinsics", intrinsics_json(frame->intrinsics)},
                      {"params", params_json(a)},
                      {"reduction", choices},
                      {"stages", stage_list},
                      {"points", points},
                      {"triangles", triangles},
                      {"bytes", glb->size()},
                      {"load_ms", load_ms},
                      {"total_ms", total_ms},
                      {"out", a.out}};
  if (auto st = write_text_file_atomic(a.report, r.dump(2) + "\n"); !st) fail(st.error());
}

void run_reduce(const ReduceArgs& a, const RosbagTopics& topics) {
  apply_malloc_settings(frame_loop_malloc_settings());
  auto so = source_options(a, topics);
  if (!so) fail(so.error());
  if (auto o = frame_options(a); !o) fail(o.error());
  auto source = open_frame_source(a.input, *so);
  if (!source) fail(source.error());
  if (a.sequence) {
    if (auto st = run_sequence(a, **source); !st) fail(st.error());
  } else {
    run_single(a, **source);
  }
}

}  // namespace

void register_reduce(CLI::App& app) {
  auto args = std::make_shared<ReduceArgs>();
  auto topics = std::make_shared<RosbagTopics>();
  CLI::App* cmd = app.add_subcommand("reduce", "Reduce RGB-D frames to a small textured mesh (GLB)");
  cmd->add_option("--input", args->input,
                  "TUM folder, color/+depth/ folder, colour image (with --depth), organized .pcd or ROS 1 .bag")
      ->required();
  cmd->add_option("--color-topic", topics->color, "ROS bag: colour sensor_msgs/Image (rgb8, bgr8, mono8)")
      ->capture_default_str();
  cmd->add_option("--depth-topic", topics->depth, "ROS bag: depth sensor_msgs/Image (16UC1 mm, 32FC1 m)")
      ->capture_default_str();
  cmd->add_option("--camera-info-topic", topics->camera_info, "ROS bag: sensor_msgs/CameraInfo (K, D)")
      ->capture_default_str();
  cmd->add_option("--frame", args->frame, "Frame index (N-th associated rgb/depth pair)");
  cmd->add_option("--depth", args->depth, "Depth PNG for a single colour image");
  cmd->add_option("--intrinsics", args->intrinsics,
                  "fr1|fr2|fr3|kinect|icl, a JSON file or a 3x3 matrix .txt file (default: guessed)");
  cmd->add_option("--depth-scale", args->depth_scale, "Raw depth units per metre (TUM 5000, mm sensors 1000)");
  cmd->add_option("--depth-encoding", args->depth_encoding,
                  "png16 (raw units), nyu (NYU Depth v2 Kinect disparity PGM) or sun (SUN3D/SUN RGB-D bit-rotated mm)")
      ->capture_default_str();
  cmd->add_option("--associations", args->associations, "TUM associations file (t_rgb rgb t_depth depth)");
  cmd->add_option("--preset", args->preset,
                  "realtime (the default: the depth image meshed adaptively, in milliseconds, under a byte budget) or "
                  "paper (the paper's pipeline exactly)")
      ->capture_default_str();
  cmd->add_option("--budget-kb", args->budget_kb,
                  "Realtime: land the GLB within +-10 % of this many kB, or under when the scene needs less "
                  "(default: 40, or a quarter of the frame's JPEG90+PNG16 payload when that is less; 0 = no budget)");
  cmd->add_option("--budget-outline-scale", args->budget_outline_texture_scale,
                  "Realtime budget: past the largest tolerance, the texture scale (0.25..1) kept before the mesh's "
                  "outline is straightened")
      ->capture_default_str();
  cmd->add_option("--budget-max-quality", args->budget_max_jpeg_quality,
                  "Realtime budget: the best JPEG quality it tries (20..100); above 92 a large budget can buy a "
                  "better texture")
      ->capture_default_str();
  cmd->add_option("--tolerance", args->params.depth_mesh.tolerance_factor,
                  "Realtime: split a triangle while its RMS distance from its pixels exceeds this many sigma of the "
                  "sensor's depth noise (a budget raises it as needed)")
      ->capture_default_str();
  cmd->add_option("--depth-noise", args->params.depth_mesh.noise_m_per_m2,
                  "Realtime: sensor depth noise sigma = NOISE * z^2 metres (Kinect-class 1.425e-3)")
      ->capture_default_str();
  cmd->add_option("--jump", args->params.depth_mesh.jump_relative,
                  "Realtime: relative depth jump between neighbouring pixels that is a discontinuity")
      ->capture_default_str();
  cmd->add_option("--speckle-px", args->params.filter.min_region_px,
                  "Realtime: drop continuous depth regions smaller than this many pixels")
      ->capture_default_str();
  cmd->add_option("--tile", args->params.depth_mesh.tile_px, "Realtime: largest triangle legs in pixels (power of two)")
      ->capture_default_str();
  cmd->add_option("--texture-deviation", args->params.depth_mesh.texture_deviation_px,
                  "Realtime: split triangles until affine texturing is within this many pixels of the projective "
                  "mapping (0 = off)")
      ->capture_default_str();
  cmd->add_option("--simplify-px", args->params.depth_mesh.simplify_px,
                  "Realtime: collapse edges while the mesh moves less than this many pixels across the image or sigma "
                  "in depth (straightens outlines; 0 = off)")
      ->capture_default_str();
  cmd->add_option("--boundary-lost-px", args->params.depth_mesh.boundary_max_lost_px,
                  "Realtime: a triangle on a hole's or the image's edge splits when keeping it whole would drop more "
                  "than this many valid pixels")
      ->capture_default_str();
  cmd->add_option("--boundary-push-px", args->params.depth_mesh.boundary_push_px,
                  "Realtime: vertices on the mesh's outline move this far outwards in the image (0..2), so the "
                  "outline's pixels are covered whole at the capture pose")
      ->capture_default_str();
  cmd->add_option("--outliers", args->params.outlier_method,
                  "Outlier neighbour search: kdtree (PCL, the paper's) or organized (image window, faster)")
      ->transform(CLI::CheckedTransformer(std::map<std::string, OutlierMethod>{
          {"kdtree", OutlierMethod::kKdTree}, {"organized", OutlierMethod::kOrganized}}))
      ->capture_default_str();
  cmd->add_option("--threads", args->params.threads,
                  "OpenMP threads of the parallel stages (normals, outliers, depth mesh); 0 = OMP_NUM_THREADS, else "
                  "the cores")
      ->capture_default_str()
      ->check(CLI::Range(0, 256));
  cmd->add_option("--outlier-k", args->params.outlier_k, "Statistical outlier removal: neighbours K")
      ->capture_default_str();
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
  cmd->add_option("--simplify", args->params.simplify_error_m,
                  "Collapse edges while the surface moves less than this many metres (0 = off)")
      ->capture_default_str();
  cmd->add_option("--texture", args->texture,
                  "atlas (undistorted per-triangle cells), footprint (cells sized to each triangle's image footprint), "
                  "frame (projective baseline) or auto (paper: atlas when triangles are large, else frame; realtime: "
                  "frame, split to 0.5 px)")
      ->capture_default_str();
  cmd->add_option("--cell-size", args->atlas.cell_size_px, "Atlas cell side in texels")->capture_default_str();
  cmd->add_option("--jpeg-quality", args->atlas.jpeg_quality, "Texture JPEG quality 1..100")->capture_default_str();
  add_flavor_option(cmd, &args->glb, "compact");
  add_geometry_codec_option(cmd, &args->glb, &args->geometry_codec_chosen);
  cmd->add_flag(
      "!--no-meshopt", args->glb.meshopt,
      "Write plain quantized buffers instead of EXT_meshopt_compression (Blender and Assimp need --flavor compat)");
  cmd->add_option("--position-step", args->glb.position_quantum_m, "Position quantization step in metres")
      ->capture_default_str();
  cmd->add_flag("--sequence", args->sequence, "Reduce the keyframes of a sequence into one multi-view GLB");
  cmd->add_option("--from", args->from, "Sequence: first frame index");
  cmd->add_option("--to", args->to, "Sequence: last frame index (inclusive; default: the last)");
  cmd->add_option("--features", args->features, "Sequence: sift|orb|akaze")->capture_default_str();
  cmd->add_option("--tracking", args->tracking,
                  "Sequence: robust (the paper's window, then a wide search, then relocalisation) | paper (the "
                  "window alone) | live (robust with exact in-window matching and a cheaper ICP; with --features orb)")
      ->capture_default_str();
  cmd->add_option("--keyframe-translation", args->keyframe_translation_m,
                  "Sequence: new keyframe after this much motion (m)")
      ->capture_default_str();
  cmd->add_option("--keyframe-rotation", args->keyframe_rotation_deg, "Sequence: ... or this much rotation (deg)")
      ->capture_default_str();
  cmd->add_option("--keyframe-overlap", args->keyframe_overlap,
                  "Sequence: ... or when overlap with the last keyframe "
                  "drops below this fraction")
      ->capture_default_str();
  cmd->add_option("--keyframe-gap", args->keyframe_gap, "Sequence: ... or after this many frames (0 = never)")
      ->capture_default_str();
  cmd->add_flag("--drop-covered,!--keep-covered", args->drop_covered,
                "Sequence: drop triangles an earlier keyframe already covers (default on)");
  cmd->add_flag("!--no-progress", args->progress, "Sequence: no progress bar");
  cmd->add_option("--trajectory", args->trajectory, "Sequence: write the estimated poses (.log Redwood, else TUM)");
  cmd->add_option("--out", args->out, "Output GLB")->required();
  cmd->add_option("--report", args->report, "Write the JSON report here");
  cmd->callback([args, topics] { run_reduce(*args, *topics); });
}

}  // namespace rgbdcast::app
