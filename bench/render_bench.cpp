// render_bench: median (and best) render time per backend of a reduced mesh, its downsampled cloud as splats and the
// full cloud as splats, at 640x480 from the capture pose (the paper's comparison: 0.27 s full splats vs 0.03 s mesh).
//
//   render_bench [--input FRAMES [--frame N] | --glb scene.glb] [--runs N] [--point-size PX]
//                [--full-point-size PX] [--backend all|vulkan|osmesa]
//
// --input (e.g. ../shared/data/tum/rgbd_dataset_freiburg1_xyz): frame N is reduced with the paper's parameters
// (reduction/pipeline.h); the mesh is the reduced vertex-coloured mesh, the downsampled cloud the voxel-grid cloud,
// the full cloud every valid pixel of the frame.
// Without --glb (or before the glTF loader is merged) it builds a synthetic Kinect-like frame: a 640x480 depth map
// of a wavy surface 1-3 m away with 75 % valid pixels, giving ~230k full-cloud points, a ~40k-triangle textured grid
// mesh and a ~20k-point downsampled cloud. With --glb, the mesh is the GLB's, the downsampled cloud its points (or
// its mesh vertices), and there is no full cloud (the lead wires the frame's cloud in with the reduction).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include "renderer/create_renderer.h"
#ifdef RGBDCAST_HAVE_GLTF
#include "gltf/gltf_io.h"
#endif
#ifdef RGBDCAST_HAVE_REDUCTION
#include "input/frame_source.h"
#include "reduction/pipeline.h"
#endif

using namespace rgbdcast;

namespace {

struct BenchScenes {
  Scene mesh, down_cloud;
  std::optional<Scene> full_cloud;
  ViewCamera camera;
  std::string source;
};

constexpr int kW = 640, kH = 480;

BenchScenes synthetic_scenes() {
  CaptureCamera cap;  // Kinect defaults: fx = fy = 525, cx = 319.5, cy = 239.5, 640x480
  auto depth_at = [](int x, int y) {
    return 2.0 + 0.6 * std::sin(x * 0.02) * std::cos(y * 0.015) + 0.3 * (static_cast<double>(y) / kH);
  };
  auto valid = [](int x, int y) { return (x * 7 + y * 13) % 4 != 0; };  // 75 % valid, like a Kinect frame
  auto color_at = [](int x, int y) {
    return Rgb8{static_cast<std::uint8_t>(x * 255 / kW), static_cast<std::uint8_t>(y * 255 / kH),
                static_cast<std::uint8_t>(((x / 16 + y / 16) % 2) * 200 + 30)};
  };
  BenchScenes s;
  s.camera = ViewCamera::from_capture(cap);
  s.source = "synthetic 640x480 frame";
  // Full cloud and the downsampled one (every 11th valid point).
  SceneNode full, down;
  long n_valid = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      if (!valid(x, y)) continue;
      const Eigen::Vector3f p = cap.intrinsics.backproject(x, y, depth_at(x, y)).cast<float>();
      full.points.positions.push_back(p);
      full.points.colors.push_back(color_at(x, y));
      if (n_valid++ % 11 == 0) {
        down.points.positions.push_back(p);
        down.points.colors.push_back(color_at(x, y));
      }
    }
  // Textured grid mesh: 160 x 128 cells = 40,960 triangles, the frame's colours as its texture.
  SceneNode mesh;
  const int cx = 160, cy = 128;
  for (int j = 0; j <= cy; ++j)
    for (int i = 0; i <= cx; ++i) {
      const double u = i * (kW - 1.0) / cx, v = j * (kH - 1.0) / cy;
      mesh.mesh.positions.push_back(cap.intrinsics.backproject(u, v, depth_at(int(u), int(v))).cast<float>());
      mesh.mesh.uvs.emplace_back((u + 0.5) / kW, (v + 0.5) / kH);
    }
  for (int j = 0; j < cy; ++j)
    for (int i = 0; i < cx; ++i) {
      const std::uint32_t a = j * (cx + 1) + i, b = a + 1, c = a + cx + 1, d = c + 1;
      mesh.mesh.indices.insert(mesh.mesh.indices.end(), {a, c, b, b, c, d});
    }
  mesh.mesh.texture = Image::make(kW, kH, 3);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const Rgb8 c = color_at(x, y);
      std::memcpy(mesh.mesh.texture.pixel(x, y), c.data(), 3);
    }
  s.mesh.nodes.push_back(std::move(mesh));
  s.down_cloud.nodes.push_back(std::move(down));
  s.full_cloud = Scene{};
  s.full_cloud->nodes.push_back(std::move(full));
  return s;
}

#ifdef RGBDCAST_HAVE_GLTF
std::optional<BenchScenes> glb_scenes(const std::string& path) {
  auto scene = read_glb_file(path);
  if (!scene) {
    std::fprintf(stderr, "render_bench: error: %s\n", scene.error().message.c_str());
    return std::nullopt;
  }
  BenchScenes s;
  s.source = path;
  CaptureCamera cap = scene->cameras.empty() ? CaptureCamera{} : scene->cameras[0];
  s.camera = ViewCamera::from_capture(cap, kW, kH);
  for (const SceneNode& n : scene->nodes) {
    SceneNode m = n, p = n;
    m.points = PointCloud{};
    if (m.mesh.triangle_count() > 0) s.mesh.nodes.push_back(std::move(m));
    if (p.points.size() == 0) p.points.positions = p.mesh.positions, p.points.colors = p.mesh.colors;
    p.mesh = Mesh{};
    if (p.points.size() > 0 && p.points.colors.size() == p.points.size()) s.down_cloud.nodes.push_back(std::move(p));
  }
  return s;
}
#endif

#ifdef RGBDCAST_HAVE_REDUCTION
std::optional<BenchScenes> frame_scenes(const std::string& path, int index) {
  auto source = open_frame_source(path, SourceOptions{});
  if (!source) {
    std::fprintf(stderr, "render_bench: error: %s\n", source.error().message.c_str());
    return std::nullopt;
  }
  auto frame = (*source)->frame(static_cast<size_t>(index));
  if (!frame) {
    std::fprintf(stderr, "render_bench: error: %s\n", frame.error().message.c_str());
    return std::nullopt;
  }
  auto reduced = reduce_frame(*frame, ReductionParams{});
  if (!reduced) {
    std::fprintf(stderr, "render_bench: error: %s\n", reduced.error().message.c_str());
    return std::nullopt;
  }
  BenchScenes s;
  s.source = path + " frame " + std::to_string(index) + " (reduced)";
  CaptureCamera cap;
  cap.intrinsics = frame->intrinsics;
  s.camera = ViewCamera::from_capture(cap);
  SceneNode mesh, down, full;
  mesh.mesh = std::move(reduced->mesh);
  down.points = std::move(reduced->cloud);
  full.points = full_cloud(*frame);
  s.mesh.nodes.push_back(std::move(mesh));
  s.down_cloud.nodes.push_back(std::move(down));
  s.full_cloud = Scene{};
  s.full_cloud->nodes.push_back(std::move(full));
  return s;
}
#endif

double median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

struct Row {
  double upload_ms = NAN, render_ms = NAN, best_render_ms = NAN, readback_ms = NAN;
  size_t primitives = 0;
};

Row measure(Renderer& r, const Scene& scene, const ViewCamera& cam, RenderMode mode, float point_size, int runs) {
  Row row;
  if (scene.nodes.empty()) return row;
  auto id = r.upload(scene, &row.upload_ms);
  if (!id) {
    std::fprintf(stderr, "render_bench: %s upload: %s\n", r.backend().c_str(), id.error().message.c_str());
    return Row{};
  }
  row.primitives = mode == RenderMode::kMesh ? scene.triangle_count() : [&] {
    size_t n = 0;
    for (const auto& node : scene.nodes) n += node.points.size();
    return n;
  }();
  RenderOptions opt;
  opt.mode = mode;
  opt.point_size_px = point_size;
  std::vector<double> render_ms, readback_ms;
  for (int i = 0; i < runs + 2; ++i) {
    auto res = r.render(id.value(), cam, opt);
    if (!res) {
      std::fprintf(stderr, "render_bench: %s render: %s\n", r.backend().c_str(), res.error().message.c_str());
      return Row{};
    }
    if (i < 2) continue;  // warm-up: shader JIT and first-touch allocations
    render_ms.push_back(res->timings.render_ms);
    readback_ms.push_back(res->timings.readback_ms);
  }
  r.release(id.value());
  row.render_ms = median(render_ms);
  row.best_render_ms = *std::min_element(render_ms.begin(), render_ms.end());
  row.readback_ms = median(readback_ms);
  return row;
}

}  // namespace

int main(int argc, char** argv) {
  std::string glb, input, backend = "all";
  int runs = 15, frame = 0;
  float point_size = 3.0f, full_point_size = 1.0f;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> const char* {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "render_bench: error: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--glb")
      glb = next();
    else if (a == "--input")
      input = next();
    else if (a == "--frame")
      frame = std::max(0, std::atoi(next()));
    else if (a == "--runs")
      runs = std::max(1, std::atoi(next()));
    else if (a == "--point-size")
      point_size = static_cast<float>(std::atof(next()));
    else if (a == "--full-point-size")
      full_point_size = static_cast<float>(std::atof(next()));
    else if (a == "--backend")
      backend = next();
    else {
      std::fprintf(stderr,
                   "usage: render_bench [--input FRAMES [--frame N] | --glb scene.glb] [--runs N] [--point-size PX] "
                   "[--full-point-size PX] [--backend all|vulkan|osmesa]\n");
      return 2;
    }
  }
  std::optional<BenchScenes> scenes;
  if (!input.empty()) {
#ifdef RGBDCAST_HAVE_REDUCTION
    scenes = frame_scenes(input, frame);
    if (!scenes) return 1;
#else
    std::fprintf(stderr, "render_bench: error: built without input/ and reduction/; --input unavailable\n");
    return 2;
#endif
  } else if (glb.empty()) {
    scenes = synthetic_scenes();
  } else {
#ifdef RGBDCAST_HAVE_GLTF
    scenes = glb_scenes(glb);
    if (!scenes) return 1;
#else
    std::fprintf(stderr, "render_bench: error: built without the glTF loader (gltf/ not merged); --glb unavailable\n");
    return 2;
#endif
  }
  std::printf("render_bench: %s, %dx%d at the capture pose, median of %d runs (after 2 warm-up)\n",
              scenes->source.c_str(), scenes->camera.width, scenes->camera.height, runs);
  std::printf("%-8s %-34s %-10s %10s %10s %12s %10s %12s\n", "backend", "device", "what", "count", "upload_ms",
              "render_ms", "best_ms", "readback_ms");
  for (BackendChoice choice : {BackendChoice::kVulkan, BackendChoice::kOsmesa}) {
    if (backend != "all" && backend != to_string(choice)) continue;
    auto sel = create_renderer(choice);
    if (!sel) {
      std::printf("%-8s unavailable: %s\n", to_string(choice), sel.error().message.c_str());
      continue;
    }
    Renderer& r = *sel->renderer;
    const Row mesh = measure(r, scenes->mesh, scenes->camera, RenderMode::kMesh, 1.0f, runs);
    const Row down = measure(r, scenes->down_cloud, scenes->camera, RenderMode::kPoints, point_size, runs);
    const Row full = scenes->full_cloud
                         ? measure(r, *scenes->full_cloud, scenes->camera, RenderMode::kPoints, full_point_size, runs)
                         : Row{};
    const std::string dev = r.device().substr(0, 34);
    auto print = [&](const char* what, const Row& row) {
      if (row.primitives == 0) return;  // not part of this scene (e.g. --glb has no full cloud)
      std::printf("%-8s %-34s %-10s %10zu %10.1f %12.2f %10.2f %12.2f\n", r.backend().c_str(), dev.c_str(), what,
                  row.primitives, row.upload_ms, row.render_ms, row.best_render_ms, row.readback_ms);
    };
    print("mesh", mesh);
    char label[32];
    std::snprintf(label, sizeof(label), "down@%gpx", point_size);
    print(label, down);
    std::snprintf(label, sizeof(label), "full@%gpx", full_point_size);
    print(label, full);
    if (full.primitives == 0) continue;
    std::printf("%-8s ratio full-splats / mesh render: %.2fx   (render+readback: %.2fx)\n", r.backend().c_str(),
                full.render_ms / mesh.render_ms,
                (full.render_ms + full.readback_ms) / (mesh.render_ms + mesh.readback_ms));
  }
  return 0;
}
