#include "app/reduce_sequence.h"

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <iostream>

#include "app/report.h"
#include "base/atomic_file.h"
#include "base/stopwatch.h"
#include "keyframes/sequence.h"
#include "keyframes/sequence_report.h"
#include "pipeline/keyframe_glb.h"

namespace rgbdcast::app {

namespace {

// A one-line progress bar on a terminal; silent when stderr is not one.
class Progress {
 public:
  explicit Progress(bool enabled) : enabled_(enabled && ::isatty(STDERR_FILENO)) {}
  void update(size_t done, size_t total, size_t keyframes, size_t bytes, const FrameRecord& last) {
    if (!enabled_) return;
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    const int width = 30, filled = total ? static_cast<int>(width * done / total) : width;
    if (last.tracked) ++tracked_;
    if (last.method == TrackMethod::kWide) ++wide_;
    if (last.method == TrackMethod::kRelocalised) ++relocalised_;
    std::fprintf(stderr,
                 "\r[%.*s%*s] %zu/%zu frames  %.1f frames/s  %zu tracked (%zu wide, %zu relocalised)  last: %-11s  "
                 "%zu keyframes  %.1f kB",
                 filled, "##############################", width - filled, "", done, total, s > 0 ? done / s : 0.0,
                 tracked_, wide_, relocalised_, last.tracked ? to_string(last.method) : "skipped", keyframes,
                 bytes / 1000.0);
    std::fflush(stderr);
  }
  void finish() {
    if (enabled_) std::fprintf(stderr, "\n");
  }

 private:
  bool enabled_;
  size_t tracked_ = 0, wide_ = 0, relocalised_ = 0;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

}  // namespace

Status run_sequence(const ReduceArgs& a, const FrameSource& source) {
  using clock = std::chrono::steady_clock;
  const auto t0 = clock::now();
  auto sequence = sequence_params(a);
  if (!sequence) return sequence.error();
  const SequenceParams params = *sequence;

  Scene scene;
  std::vector<CoverageView> earlier;
  nlohmann::json keyframes = nlohmann::json::array();
  size_t bytes_so_far = 0, keyframe_count = 0;
  Progress progress(a.progress);

  auto options = frame_options(a);
  if (!options) return options.error();
  auto on_keyframe = [&](const RgbdFrame& frame, const FrameRecord& record) -> Status {
    // (The default budget is each keyframe's own: budget_within_payload_share.)
    auto textured =
        reduce_and_texture(frame, *options, record.pose, a.drop_covered ? earlier : std::vector<CoverageView>{});
    if (!textured) return textured.error();
    bytes_so_far += textured->node.mesh.texture_encoded.size() + textured->node.mesh.positions.size() * 10;
    keyframes.push_back({{"index", record.index},
                         {"triangles", textured->node.mesh.triangle_count()},
                         {"texels", textured->atlas_stats.texels},
                         {"reduction", reduction_choices(*textured)},
                         {"stages", stages_json(textured->stages)}});
    scene.cameras.push_back(textured->camera);
    scene.nodes.push_back(std::move(textured->node));
    earlier.push_back({frame.intrinsics, frame.depth_m, record.pose});
    ++keyframe_count;
    return ok_status();
  };
  auto on_progress = [&](const FrameRecord& record, size_t done, size_t total) {
    progress.update(done, total, keyframe_count, bytes_so_far, record);
  };
  auto result = track_sequence(
      source.size(), [&](size_t i) { return source.frame(i); }, params, on_keyframe, on_progress);
  progress.finish();
  if (!result) return result.error();
  if (scene.nodes.empty()) return make_error(ErrorCode::kEmpty, "no keyframe could be reduced");

  nlohmann::json extras = {{"rgbdcast", {{"input", a.input}, {"keyframes", keyframes}}}};
  scene.extras_json = extras.dump();
  GlbStats stats;
  auto glb = encode_glb(scene, options->glb, &stats);  // the codec the budget measured with
  if (!glb) return glb.error();
  if (auto st = write_file_atomically(a.out, *glb); !st) return st;
  if (!a.trajectory.empty()) {
    const Trajectory t = result->trajectory();
    const bool log = a.trajectory.size() > 4 && a.trajectory.substr(a.trajectory.size() - 4) == ".log";
    if (auto st = log ? write_redwood_log(a.trajectory, t) : write_tum_trajectory(a.trajectory, t); !st) return st;
  }
  const double total_ms = ms_since(t0);

  std::cout << "rgbdcast reduce --sequence: " << result->frames.size() << " frames, " << result->tracked << " tracked ("
            << result->widened << " by the wide search, " << result->relocalised << " relocalised), "
            << result->keyframes << " keyframes, " << result->skipped << " skipped; " << scene.triangle_count()
            << " triangles, " << glb->size() << " bytes (geometry " << stats.geometry_bytes << ", texture "
            << stats.texture_bytes << ") -> " << a.out << " (" << static_cast<int>(total_ms) << " ms)\n";
  for (const auto& f : result->frames)
    if (!f.message.empty() && !f.tracked) std::cout << "  frame " << f.index << ": " << f.message << "\n";
  if (a.report.empty()) return ok_status();
  nlohmann::json r = {{"input", a.input},
                      {"sequence", true},
                      {"features", a.features},
                      {"tracking", a.tracking},
                      {"tracked", result->tracked},
                      {"tracked_wide", result->widened},
                      {"tracked_relocalised", result->relocalised},
                      {"drop_covered", a.drop_covered},
                      {"params", params_json(a)},
                      {"frames", frames_json(*result)},
                      {"keyframes", keyframes},
                      {"points", scene.vertex_count()},
                      {"triangles", scene.triangle_count()},
                      {"bytes", glb->size()},
                      {"export",
                       {{"bytes", stats.total_bytes},
                        {"geometry_bytes", stats.geometry_bytes},
                        {"texture_bytes", stats.texture_bytes},
                        {"json_bytes", stats.json_bytes},
                        {"ms", stats.ms}}},
                      {"total_ms", total_ms},
                      {"out", a.out}};
  return write_text_file_atomic(a.report, r.dump(2) + "\n");
}

}  // namespace rgbdcast::app
