// atlas_bench: measures the texture atlas and the GLB export on a real frame (default: TUM fr1/xyz frame 0).
// Prints: the distribution of source pixels per triangle; for each cell size / gutter / JPEG quality, the atlas
// size, JPEG bytes and the texture's fidelity to the frame (PSNR on the surface, texture_fidelity.h); the frame
// baseline; geometry bytes with and without KHR_mesh_quantization and EXT_meshopt_compression; and median times.
// With --footprint: the footprint atlas (TextureMode::kFootprint) and the frame texture on meshes shaped like the
// realtime preset's (right isosceles triangles on the depth image, tests/atlas/right_triangle_mesh.h) of 5k-20k
// triangles: build ms (without JPEG), packing, fill ms, JPEG bytes with and without the fill at q 50-85, PSNR.
// Usage: atlas_bench [TUM folder] [frame] [--organized] [--footprint [--repeat N]]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <string>

#include "atlas/atlas.h"
#include "atlas/footprint_layout.h"
#include "atlas/texture_fidelity.h"
#include "atlas/triangle_homography.h"
#include "gltf/gltf_io.h"
#include "input/frame_source.h"
#include "reduction/pipeline.h"
#include "tests/atlas/right_triangle_mesh.h"

using namespace rgbdcast;

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[std::min(v.size() - 1, static_cast<size_t>(p * v.size()))];
}

Scene scene_of(const Mesh& m, const RgbdFrame& f) {
  Scene s;
  SceneNode n;
  n.name = "frame_" + std::to_string(f.index);
  n.mesh = m;
  s.nodes.push_back(n);
  CaptureCamera cam;
  cam.intrinsics = f.intrinsics;
  cam.timestamp = f.timestamp;
  cam.source = f.color_path;
  cam.frame_index = f.index;
  s.cameras.push_back(cam);
  s.extras_json = R"({"rgbdcast":{"bench":true}})";
  return s;
}

// One texture build, repeated: the median and fastest build time (ms, without JPEG) and fill time, the last result.
struct Timed {
  Result<AtlasResult> last = make_error(ErrorCode::kInternal, "not run");
  double ms = 0, min_ms = 0, fill_ms = 0, encode_ms = 0;
};

Timed timed_build(const Mesh& mesh, const RgbdFrame& f, const AtlasOptions& o, int runs) {
  Timed t;
  std::vector<double> ms, fill, enc;
  for (int run = 0; run < runs; ++run) {
    t.last = build_atlas(mesh, f.color_rgb, f.intrinsics, o);
    if (!t.last) return t;
    ms.push_back(t.last->ms);
    fill.push_back(t.last->fill_ms);
    enc.push_back(t.last->encode_ms);
  }
  t.ms = median(ms);
  t.min_ms = *std::min_element(ms.begin(), ms.end());
  t.fill_ms = median(fill);
  t.encode_ms = median(enc);
  return t;
}

// Only builds, for a profiler or `perf stat` (wall times on a shared machine are noisy): `runs` footprint atlases
// of the 22k-triangle mesh, fill included; prints the fastest.
int footprint_repeat(const RgbdFrame& f, int runs) {
  const Mesh mesh = test::right_triangle_mesh_of_depth(f.depth_m, f.intrinsics, 16.0);
  for (bool reorder : {true, false}) {
    AtlasOptions o;
    o.mode = TextureMode::kFootprint;
    o.reorder_triangles = reorder;
    const Timed t = timed_build(mesh, f, o, runs);
    if (!t.last) return std::fprintf(stderr, "%s\n", t.last.error().message.c_str()), 1;
    std::printf(
        "%zu triangles, %dx%d, reorder %s: fastest build %.2f ms, median %.2f ms (fill %.2f ms) over %d runs; "
        "JPEG q%d %zu B\n",
        t.last->triangles, t.last->width, t.last->height, reorder ? "on " : "off", t.min_ms, t.ms, t.fill_ms, runs,
        o.jpeg_quality, t.last->mesh.texture_encoded.size());
  }
  return 0;
}

int footprint_rows(const RgbdFrame& f) {
  std::printf("%-9s %6s %7s %9s %7s %7s %9s %8s %8s %3s %9s %9s %8s %8s\n", "mode", "tol", "tris", "atlas", "pack",
              "cells%", "build ms", "min ms", "fill ms", "q", "jpeg fill", "jpeg raw", "PSNR f", "PSNR r");
  for (const auto& [tol, min_side] : std::vector<std::pair<double, int>>{{16.0, 2}, {16.0, 4}, {16.0, 8}, {1.0, 8}}) {
    test::RightTriangleMeshOptions mo;
    mo.min_side_px = min_side;
    const Mesh mesh = test::right_triangle_mesh_of_depth(f.depth_m, f.intrinsics, tol, mo);
    // Where the footprint atlas's texels go: triangles and cell texels per leg class.
    std::map<int, std::pair<size_t, double>> by_leg;
    for (size_t t = 0; t < mesh.triangle_count(); ++t) {
      std::array<Eigen::Vector2d, 3> px;
      for (int i = 0; i < 3; ++i) px[i] = f.intrinsics.project(mesh.positions[mesh.indices[3 * t + i]].cast<double>());
      const int leg = footprint_leg_class(footprint_leg_px(px, nullptr));
      by_leg[leg].first += 1;
      by_leg[leg].second += 0.5 * (leg + 4) * (leg + 4);  // half a cell (gutter 1)
    }
    std::printf(
        "# tolerance %.0f x 1.425e-3 z^2, blocks >= %d px: %zu triangles, %zu vertices. Per leg class "
        "(texels): triangles / share of the cells' texels:",
        tol, min_side, mesh.triangle_count(), mesh.positions.size());
    double all = 0;
    for (const auto& [leg, v] : by_leg) all += v.second;
    for (const auto& [leg, v] : by_leg) std::printf(" %d: %zu / %.0f%%", leg, v.first, 100.0 * v.second / all);
    std::printf("\n");
    for (const char* variant : {"fp cells", "fp+patch", "fp+patch64", "frame"})
      for (int q : {50, 70, 85}) {
        const std::string name = variant;
        const TextureMode mode = name == "frame" ? TextureMode::kFrame : TextureMode::kFootprint;
        AtlasOptions filled, raw;
        filled.mode = raw.mode = mode;
        filled.footprint_patch_deviation_px = raw.footprint_patch_deviation_px =
            name.rfind("fp+patch", 0) == 0 ? 0.25 : 0;
        filled.footprint_patch_tile_px = raw.footprint_patch_tile_px = name == "fp+patch64" ? 64 : 32;
        filled.jpeg_quality = raw.jpeg_quality = q;
        filled.fill_unsampled = true;
        raw.fill_unsampled = false;
        const int runs = q == 50 ? 15 : 1;  // time once per mode and mesh
        const Timed a = timed_build(mesh, f, filled, runs), b = timed_build(mesh, f, raw, 1);
        if (!a.last || !b.last) {
          const Error& e = !a.last ? a.last.error() : b.last.error();
          return std::fprintf(stderr, "%s\n", e.message.c_str()), 1;
        }
        const TextureFidelity fa =
            measure_texture_fidelity(a.last->mesh, decode_texture(a.last->mesh), f.color_rgb, f.intrinsics);
        const TextureFidelity fb =
            measure_texture_fidelity(b.last->mesh, decode_texture(b.last->mesh), f.color_rgb, f.intrinsics);
        char size[32], build[16], fastest[16], fill[16];
        std::snprintf(size, sizeof size, "%dx%d", a.last->width, a.last->height);
        std::snprintf(build, sizeof build, "%.2f", a.ms);
        std::snprintf(fastest, sizeof fastest, "%.2f", a.min_ms);
        std::snprintf(fill, sizeof fill, "%.2f", a.fill_ms);
        const double cells = 100.0 * (1.0 - double(a.last->unsampled_texels) / double(a.last->texels));
        std::printf("%-9s %6.1f %7zu %9s %7.3f %7.1f %9s %8s %8s %3d %9zu %9zu %8.2f %8.2f\n", variant, tol,
                    a.last->triangles, size, a.last->packing_efficiency, cells, runs > 1 ? build : "",
                    runs > 1 ? fastest : "", runs > 1 ? fill : "", q, a.last->mesh.texture_encoded.size(),
                    b.last->mesh.texture_encoded.size(), fa.psnr_db, fb.psnr_db);
      }
  }
  std::printf(
      "fp cells = footprint, every triangle in a cell; fp+patch(64) = footprint with frame patches of 32 (64, "
      "the default) px tiles for triangles within 0.25 px of projective (the rest in cells); "
      "pack = triangle texels / atlas texels; cells%% = sampled texels (cells' triangles + gutters; frame: "
      "pixels some triangle reads); build ms = median of 15 runs (wall), min ms = fastest of them (the machine is "
      "shared), fill included, JPEG excluded\n");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::string folder = std::string(RGBDCAST_DATA_DIR) + "/tum/rgbd_dataset_freiburg1_xyz";
  int frame_index = 0;
  ReductionParams params;
  bool footprint = false;
  int repeat = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--organized")
      params.outlier_method = OutlierMethod::kOrganized;
    else if (a == "--footprint")
      footprint = true;
    else if (a == "--repeat" && i + 1 < argc)
      repeat = std::stoi(argv[++i]);
    else if (i == 1)
      folder = a;
    else
      frame_index = std::stoi(a);
  }
  auto source = open_frame_source(folder, {});
  if (!source) return std::fprintf(stderr, "%s\n", source.error().message.c_str()), 1;
  auto frame = (*source)->frame(frame_index);
  if (!frame) return std::fprintf(stderr, "%s\n", frame.error().message.c_str()), 1;
  if (footprint && repeat > 0) return footprint_repeat(*frame, repeat);
  if (footprint) {
    std::printf("frame %d of %s\n", frame_index, folder.c_str());
    return footprint_rows(*frame);
  }
  auto reduced = reduce_frame(*frame, params);
  if (!reduced) return std::fprintf(stderr, "%s\n", reduced.error().message.c_str()), 1;
  const Mesh& mesh = reduced->mesh;
  const Intrinsics& k = frame->intrinsics;
  std::printf("frame %d of %s: %zu vertices, %zu triangles (reduction: %s outliers)\n", frame_index, folder.c_str(),
              mesh.positions.size(), mesh.triangle_count(),
              params.outlier_method == OutlierMethod::kOrganized ? "organized" : "k-d tree");

  // Source pixels per triangle.
  std::vector<double> area;
  for (size_t t = 0; t < mesh.triangle_count(); ++t)
    area.push_back(projected_area_px(mesh.positions[mesh.indices[3 * t]].cast<double>(),
                                     mesh.positions[mesh.indices[3 * t + 1]].cast<double>(),
                                     mesh.positions[mesh.indices[3 * t + 2]].cast<double>(), k.K()));
  double covered = 0;
  for (double a : area) covered += a;
  std::printf(
      "\nsource pixels per triangle: p10 %.1f  p50 %.1f  p90 %.1f  p99 %.1f  max %.1f  (sum %.0f px = %.0f%% of the "
      "frame)\n",
      percentile(area, 0.1), percentile(area, 0.5), percentile(area, 0.9), percentile(area, 0.99),
      percentile(area, 1.0), covered, 100.0 * covered / (double(k.width) * k.height));
  std::printf(
      "texels per triangle (its own area in the cell, two per cell, gutter 1): cell 6: %.1f, 8: %.1f, 12: %.1f, 16: "
      "%.1f\n",
      0.5 * 2 * 2, 0.5 * 4 * 4, 0.5 * 8 * 8, 0.5 * 12 * 12);

  // Texture variants.
  std::printf("\n%-6s %5s %4s %4s %3s %11s %9s %10s %9s %9s %9s\n", "mode", "cell", "gut", "2/c", "q", "atlas",
              "texels", "jpeg B", "PSNR dB", "atlas ms", "jpeg ms");
  struct Row {
    TextureMode mode;
    int cell, gutter;
    bool two;
    int q;
  };
  std::vector<Row> rows;
  for (int q : {50, 70, 85, 95}) rows.push_back({TextureMode::kFrame, 0, 0, true, q});
  for (int cell : {6, 8, 12, 16})
    for (int q : {50, 70, 85, 95}) rows.push_back({TextureMode::kAtlas, cell, 1, true, q});
  for (int g : {0, 2}) rows.push_back({TextureMode::kAtlas, 8, g, true, 85});
  rows.push_back({TextureMode::kAtlas, 8, 1, false, 85});
  for (const Row& r : rows) {
    AtlasOptions o;
    o.mode = r.mode;
    o.cell_size_px = std::max(r.cell, 2);
    o.gutter_px = r.gutter;
    o.two_per_cell = r.two;
    o.jpeg_quality = r.q;
    if (r.mode == TextureMode::kAtlas && r.cell < 3 * r.gutter + 2) continue;
    std::vector<double> ms, enc;
    Result<AtlasResult> res = make_error(ErrorCode::kInternal, "not run");
    for (int run = 0; run < 3; ++run) {
      res = build_atlas(mesh, frame->color_rgb, k, o);
      if (!res) return std::fprintf(stderr, "%s\n", res.error().message.c_str()), 1;
      ms.push_back(res->ms);
      enc.push_back(res->encode_ms);
    }
    const Image decoded = decode_texture(res->mesh);
    const TextureFidelity fid = measure_texture_fidelity(res->mesh, decoded, frame->color_rgb, k);
    char size[32];
    std::snprintf(size, sizeof size, "%dx%d", res->width, res->height);
    std::printf("%-6s %5d %4d %4s %3d %11s %9zu %10zu %9.2f %9.1f %9.1f\n", to_string(r.mode), r.cell, r.gutter,
                r.two ? "yes" : "no", r.q, size, res->texels, res->mesh.texture_encoded.size(), fid.psnr_db, median(ms),
                median(enc));
  }

  // Geometry bytes.
  std::printf("\n%-6s %-9s %-8s %12s %12s %12s %12s %10s\n", "mode", "quantize", "meshopt", "geometry B", "texture B",
              "json B", "GLB B", "export ms");
  for (TextureMode mode : {TextureMode::kAtlas, TextureMode::kFrame}) {
    AtlasOptions o;
    o.mode = mode;
    auto res = build_atlas(mesh, frame->color_rgb, k, o);
    if (!res) return 1;
    const Scene scene = scene_of(res->mesh, *frame);
    for (bool quantize : {false, true})
      for (bool meshopt : {false, true}) {
        GlbWriteOptions w;
        w.quantize = quantize;
        w.meshopt = meshopt;
        GlbStats st;
        std::vector<double> ms;
        for (int run = 0; run < 5; ++run) {
          auto glb = encode_glb(scene, w, &st);
          if (!glb) return std::fprintf(stderr, "%s\n", glb.error().message.c_str()), 1;
          ms.push_back(st.ms);
        }
        std::printf("%-6s %-9s %-8s %12zu %12zu %12zu %12zu %10.1f\n", to_string(mode), quantize ? "yes" : "no",
                    meshopt ? "yes" : "no", st.geometry_bytes, st.texture_bytes, st.json_bytes, st.total_bytes,
                    median(ms));
      }
  }
  // Position quantization step (KHR_mesh_quantization + meshopt).
  std::printf("\n%-6s %10s %12s %12s\n", "mode", "quantum mm", "geometry B", "GLB B");
  for (TextureMode mode : {TextureMode::kAtlas, TextureMode::kFrame}) {
    AtlasOptions o;
    o.mode = mode;
    auto res = build_atlas(mesh, frame->color_rgb, k, o);
    if (!res) return 1;
    const Scene scene = scene_of(res->mesh, *frame);
    for (double q_mm : {0.25, 0.5, 1.0, 2.0}) {
      GlbWriteOptions w;
      w.meshopt = true;
      w.position_quantum_m = q_mm / 1000.0;
      GlbStats st;
      if (!encode_glb(scene, w, &st)) return 1;
      std::printf("%-6s %10.2f %12zu %12zu\n", to_string(mode), q_mm, st.geometry_bytes, st.total_bytes);
    }
  }
  // The vertex-coloured mesh (no texture) for comparison.
  {
    Scene scene = scene_of(mesh, *frame);
    GlbWriteOptions w;
    w.meshopt = true;
    GlbStats st;
    auto glb = encode_glb(scene, w, &st);
    if (glb)
      std::printf("%-6s %-9s %-8s %12zu %12zu %12zu %12zu %10.1f\n", "vcolor", "yes", "yes", st.geometry_bytes,
                  st.texture_bytes, st.json_bytes, st.total_bytes, st.ms);
  }
  std::printf("\nraw cloud: 307200 x (3 float + RGB) = %d bytes\n", 307200 * 15);
  return 0;
}
