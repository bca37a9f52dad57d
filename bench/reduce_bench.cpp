// Per-stage times of the reduction on real frames: median of N runs per stage, printed as a table.
// usage: reduce_bench [--input DIR] [--intrinsics fr1 (default: guessed from the input, as reduce does)] [--frame 0]
// [--runs 5] [--preset paper|realtime]
//                     [--budget-kb 40] [--threads N (realtime; 0 = OpenMP's default)] [--tile 128 (realtime)]
// The paper preset (default) is timed with both outlier searches. The realtime preset is timed through the one
// frame -> scene function and the GLB encode, as `rgbdcast reduce` runs it (Draco geometry, the budget), with its
// stages and the whole wall time (this is the loop to profile: `perf record -g reduce_bench --preset realtime`).
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <map>
#include <string>
#include <vector>

#include <chrono>

#include "base/malloc_settings.h"
#include "base/stopwatch.h"
#include "gltf/gltf_io.h"
#include "input/frame_source.h"
#include "pipeline/frame_scene.h"
#include "reduction/pipeline.h"
#include "reduction/stages.h"

using namespace rgbdcast;

static double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

// The realtime preset through reduce_and_texture + encode_glb: stage medians and the wall time of the whole.
static int realtime_stages(const RgbdFrame& frame, const std::string& input, int frame_index, int runs,
                           double budget_kb, int threads, int tile) {
  FrameReductionOptions o;
  o.params = reduction_preset(Preset::kRealtime);
  if (tile > 0) o.params.depth_mesh.tile_px = tile;
  o.glb.geometry_codec = GeometryCodec::kDraco;  // as `rgbdcast reduce --preset realtime`
  o.budget_kb = budget_kb;
  o.params.threads = threads;
  std::vector<std::string> order;
  std::map<std::string, std::vector<double>> ms;
  std::map<std::string, size_t> count;
  std::vector<double> wall;
  size_t bytes = 0;
  int encodes = 0, meshes = 0;
  for (int r = 0; r < runs; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    auto textured = reduce_and_texture(frame, o);
    if (!textured) return std::fprintf(stderr, "reduce_bench: %s\n", textured.error().message.c_str()), 1;
    const std::vector<StageReport> stages = textured->stages;
    encodes = textured->budget.encodes;
    meshes = textured->budget.meshes;
    const GlbWriteOptions glb_options = write_options(*textured, o.glb);
    auto glb = encode_glb(frame_scene(std::move(*textured), ""), glb_options);
    if (!glb) return std::fprintf(stderr, "reduce_bench: %s\n", glb.error().message.c_str()), 1;
    wall.push_back(ms_since(t0));
    bytes = glb->size();
    for (const auto& s : stages) {
      if (!ms.count(s.name)) order.push_back(s.name);
      ms[s.name].push_back(s.ms);
      count[s.name] = s.count;
    }
  }
  std::printf("reduce_bench: %s frame %d, realtime preset, budget %.0f kB, %d runs (median ms)\n", input.c_str(),
              frame_index, budget_kb, runs);
  auto min_of = [](const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); };
  std::printf("%-12s %10s %10s %10s\n", "stage", "count", "median_ms", "min_ms");
  for (const auto& name : order)
    std::printf("%-12s %10zu %10.1f %10.1f\n", name.c_str(), count[name], median(ms[name]), min_of(ms[name]));
  std::printf("%-12s %10zu %10.1f %10.1f   (GLB bytes; %d meshes and %d encodes in the budget)\n", "wall", bytes,
              median(wall), min_of(wall), meshes, encodes);
  return 0;
}

int main(int argc, char** argv) {
  apply_malloc_settings(frame_loop_malloc_settings());  // as `rgbdcast reduce` and `rgbdcast stream` run
  std::string input = RGBDCAST_DATA_DIR "/tum/rgbd_dataset_freiburg1_xyz", intrinsics;
  int frame_index = 0, runs = 5;
  std::string preset = "paper";
  double budget_kb = 40;
  int threads = 0, tile = 0;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--input"))
      input = argv[i + 1];
    else if (!std::strcmp(argv[i], "--intrinsics"))
      intrinsics = argv[i + 1];
    else if (!std::strcmp(argv[i], "--frame"))
      frame_index = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--runs"))
      runs = std::max(1, std::atoi(argv[i + 1]));
    else if (!std::strcmp(argv[i], "--preset"))
      preset = argv[i + 1];
    else if (!std::strcmp(argv[i], "--budget-kb"))
      budget_kb = std::atof(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--threads"))
      threads = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--tile"))
      tile = std::atoi(argv[i + 1]);
  }
  SourceOptions o;
  o.intrinsics = intrinsics;
  auto src = open_frame_source(input, o);
  if (!src) return std::fprintf(stderr, "reduce_bench: %s\n", src.error().message.c_str()), 1;
  auto frame = (*src)->frame(frame_index);
  if (!frame) return std::fprintf(stderr, "reduce_bench: %s\n", frame.error().message.c_str()), 1;

  if (preset == "realtime") return realtime_stages(*frame, input, frame_index, runs, budget_kb, threads, tile);
  if (preset != "paper") return std::fprintf(stderr, "reduce_bench: --preset must be paper or realtime\n"), 1;

  // How far the organized outlier search agrees with PCL's k-d tree search on this frame.
  {
    std::vector<int> pixel_of_point;
    Cloud::Ptr valid = backproject_valid(*frame, &pixel_of_point);
    const ReductionParams p;
    std::vector<int> a = statistical_outliers_kdtree(valid, p.outlier_k, p.outlier_std_mul);
    std::vector<int> b = statistical_outliers_organized(*valid, pixel_of_point, frame->depth_m.cols,
                                                        frame->depth_m.rows, p.outlier_k, p.outlier_std_mul);
    std::vector<int> both;
    std::set_intersection(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(both));
    const size_t removed_a = valid->size() - a.size(), removed_b = valid->size() - b.size();
    std::printf(
        "outlier agreement: %zu valid; kdtree keeps %zu (removes %zu), organized keeps %zu (removes %zu); "
        "kept by both %zu, Jaccard %.4f\n\n",
        valid->size(), a.size(), removed_a, b.size(), removed_b, both.size(),
        double(both.size()) / double(a.size() + b.size() - both.size()));
  }
  for (OutlierMethod method : {OutlierMethod::kKdTree, OutlierMethod::kOrganized}) {
    std::vector<std::string> order;
    std::map<std::string, std::vector<double>> ms;
    std::map<std::string, size_t> count;
    std::map<std::string, std::string> unit;
    std::vector<double> total;
    ReductionParams params;
    params.outlier_method = method;
    for (int r = 0; r < runs; ++r) {
      auto out = reduce_frame(*frame, params);
      if (!out) return std::fprintf(stderr, "reduce_bench: %s\n", out.error().message.c_str()), 1;
      double t = 0;
      for (const auto& s : out->stages) {
        if (r == 0) order.push_back(s.name);
        ms[s.name].push_back(s.ms);
        count[s.name] = s.count;
        unit[s.name] = s.unit;
        t += s.ms;
      }
      total.push_back(t);
    }
    std::printf("reduce_bench: %s frame %d, outliers=%s, %d runs (median ms)\n", input.c_str(), frame_index,
                method == OutlierMethod::kKdTree ? "kdtree" : "organized", runs);
    std::printf("%-12s %10s %-10s %10s\n", "stage", "count", "unit", "median_ms");
    for (const auto& name : order)
      std::printf("%-12s %10zu %-10s %10.1f\n", name.c_str(), count[name], unit[name].c_str(), median(ms[name]));
    std::printf("%-12s %10s %-10s %10.1f\n\n", "total", "", "", median(total));
  }
  return 0;
}
