// atlas_bench: measures the texture atlas and the GLB export on a real frame (default: TUM fr1/xyz frame 0).
// Prints: the distribution of source pixels per triangle; for each cell size / gutter / JPEG quality, the atlas
// size, JPEG bytes and the texture's fidelity to the frame (PSNR on the surface, texture_fidelity.h); the frame
// baseline; geometry bytes with and without KHR_mesh_quantization and EXT_meshopt_compression; and median times.
// Usage: atlas_bench [TUM folder] [frame] [--organized]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>

#include "atlas/atlas.h"
#include "atlas/texture_fidelity.h"
#include "atlas/triangle_homography.h"
#include "gltf/gltf_io.h"
#include "input/frame_source.h"
#include "reduction/pipeline.h"

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

}  // namespace

int main(int argc, char** argv) {
  std::string folder = std::string(RGBDCAST_DATA_DIR) + "/tum/rgbd_dataset_freiburg1_xyz";
  int frame_index = 0;
  ReductionParams params;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--organized")
      params.outlier_method = OutlierMethod::kOrganized;
    else if (i == 1)
      folder = a;
    else
      frame_index = std::stoi(a);
  }
  auto source = open_frame_source(folder, {});
  if (!source) return std::fprintf(stderr, "%s\n", source.error().message.c_str()), 1;
  auto frame = (*source)->frame(frame_index);
  if (!frame) return std::fprintf(stderr, "%s\n", frame.error().message.c_str()), 1;
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
  std::printf("\nsource pixels per triangle: p10 %.1f  p50 %.1f  p90 %.1f  p99 %.1f  max %.1f  (sum %.0f px = %.0f%% of the frame)\n",
              percentile(area, 0.1), percentile(area, 0.5), percentile(area, 0.9), percentile(area, 0.99),
              percentile(area, 1.0), covered, 100.0 * covered / (double(k.width) * k.height));
  std::printf("texels per triangle (its own area in the cell, two per cell, gutter 1): cell 6: %.1f, 8: %.1f, 12: %.1f, 16: %.1f\n",
              0.5 * 2 * 2, 0.5 * 4 * 4, 0.5 * 8 * 8, 0.5 * 12 * 12);

  // Texture variants.
  std::printf("\n%-6s %5s %4s %4s %3s %11s %9s %10s %9s %9s %9s\n", "mode", "cell", "gut", "2/c", "q", "atlas", "texels",
              "jpeg B", "PSNR dB", "atlas ms", "jpeg ms");
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
                r.two ? "yes" : "no", r.q, size, res->texels, res->mesh.texture_encoded.size(), fid.psnr_db,
                median(ms), median(enc));
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
    if (glb) std::printf("%-6s %-9s %-8s %12zu %12zu %12zu %12zu %10.1f\n", "vcolor", "yes", "yes", st.geometry_bytes,
                         st.texture_bytes, st.json_bytes, st.total_bytes, st.ms);
  }
  std::printf("\nraw cloud: 307200 x (3 float + RGB) = %d bytes\n", 307200 * 15);
  return 0;
}
