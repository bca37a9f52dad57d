// geometry_codec_bench: the compact flavour's two geometry codecs (gltf/gltf_io.h GeometryCodec) on real frames
// reduced with the realtime preset at its default settings (40 kB budget).
//  A. The same mesh (the one the default budget chose with meshopt) encoded with EXT_meshopt_compression +
//     KHR_mesh_quantization and with KHR_draco_mesh_compression at Draco speeds 0, 5, 7 and 10: geometry bytes,
//     bytes a triangle, encode_glb ms, the decompress pass's ms (the geometry decode alone) and decode_glb ms
//     (geometry + JPEG texture + scene), as CPU time of the calling thread (all three are single-threaded), which
//     holds on a shared machine. Medians over frames of the median of --runs runs.
//  B. The whole realtime reduction with its 40 kB budget, once per codec (the budget spends what Draco saves on
//     a finer mesh or a better texture): GLB bytes, triangles, the budget's rule, frame -> GLB CPU ms (summed over
//     the process's threads) and wall ms.
// Usage: geometry_codec_bench [--runs N] [--data DIR]
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "bench/bench_stats.h"
#include "gltf/draco_buffers.h"
#include "gltf/glb_container.h"
#include "gltf/gltf_io.h"
#include "gltf/meshopt_buffers.h"
#include "input/frame_source.h"
#include "pipeline/frame_scene.h"

using namespace rgbdcast;
using namespace rgbdcast::bench;

namespace {

struct Set {
  std::string path, intrinsics;
  std::vector<size_t> frames;
};

// 23 TUM frames (fr1/xyz 0-2, every 6th of the 120-frame excerpt) and 10 ICL frames (0-4 of each living room).
std::vector<Set> sets() {
  std::vector<size_t> excerpt;
  for (size_t i = 0; i < 120; i += 6) excerpt.push_back(i);
  return {{"tum/rgbd_dataset_freiburg1_xyz", "fr1", {0, 1, 2}},
          {"tum/rgbd_dataset_freiburg1_xyz_200_319", "fr1", excerpt},
          {"icl_nuim_livingroom", "", {0, 1, 2, 3, 4}},
          {"augmented_icl_livingroom", "", {0, 1, 2, 3, 4}}};
}

struct Codec {
  std::string name;
  GlbWriteOptions options;
};

std::vector<Codec> codecs() {
  std::vector<Codec> c;
  c.push_back({"meshopt", {}});
  for (int speed : {0, 5, 7, 10}) {
    GlbWriteOptions o;
    o.geometry_codec = GeometryCodec::kDraco;
    o.draco.encode_speed = o.draco.decode_speed = speed;
    c.push_back({"draco speed " + std::to_string(speed), o});
  }
  return c;
}

struct Row {
  std::vector<double> geometry, per_triangle, encode_ms, pass_ms, decode_ms;
};

FrameReductionOptions realtime(GeometryCodec codec) {
  FrameReductionOptions o;
  o.params = reduction_preset(Preset::kRealtime);
  o.budget_kb = 40;
  o.glb.geometry_codec = codec;
  return o;
}

}  // namespace

int main(int argc, char** argv) {
  int runs = 3;
  std::string data = RGBDCAST_DATA_DIR;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--runs") && i + 1 < argc)
      runs = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--data") && i + 1 < argc)
      data = argv[++i];
    else {
      std::fprintf(stderr, "usage: geometry_codec_bench [--runs N] [--data DIR]\n");
      return 2;
    }
  }
  const auto list = codecs();
  std::map<std::string, Row> rows;
  struct Budget {
    std::vector<double> bytes, triangles, ms, cpu;
    int over = 0;
  };
  std::map<std::string, Budget> budget;
  int frames = 0;
  for (const Set& set : sets()) {
    SourceOptions so;
    so.intrinsics = set.intrinsics;
    auto src = open_frame_source(data + "/" + set.path, so);
    if (!src) {
      std::fprintf(stderr, "geometry_codec_bench: %s: %s\n", set.path.c_str(), src.error().message.c_str());
      return 1;
    }
    for (size_t index : set.frames) {
      auto frame = (*src)->frame(index);
      if (!frame) {
        std::fprintf(stderr, "geometry_codec_bench: %s %zu: %s\n", set.path.c_str(), index,
                     frame.error().message.c_str());
        return 1;
      }
      ++frames;
      // B: the budgeted reduction, per codec.
      Scene scene;
      for (GeometryCodec codec : {GeometryCodec::kMeshopt, GeometryCodec::kDraco}) {
        Budget& b = budget[to_string(codec)];
        std::vector<double> ms, cpu;
        Result<TexturedFrame> t = make_error(ErrorCode::kInternal, "not run");
        std::vector<std::uint8_t> glb;
        for (int r = 0; r < runs; ++r) {
          double wall = 0;
          cpu.push_back(cpu_ms(
              [&] {
                wall = time_ms([&] {
                  t = reduce_and_texture(*frame, realtime(codec));
                  if (t) {
                    auto bytes = encode_glb(frame_scene(TexturedFrame(*t), ""), realtime(codec).glb);
                    if (bytes) glb = std::move(*bytes);
                  }
                });
              },
              CLOCK_PROCESS_CPUTIME_ID));
          ms.push_back(wall);
          if (!t) {
            std::fprintf(stderr, "geometry_codec_bench: %s\n", t.error().message.c_str());
            return 1;
          }
        }
        b.ms.push_back(median(ms));
        b.cpu.push_back(median(cpu));
        b.bytes.push_back(double(glb.size()));
        b.triangles.push_back(double(t->node.mesh.triangle_count()));
        b.over += t->budget.rule == "over-budget";
        if (codec == GeometryCodec::kMeshopt) scene = frame_scene(std::move(*t), "");
      }
      // A: the meshopt budget's mesh in every codec.
      const double triangles = double(scene.nodes[0].mesh.triangle_count());
      for (const Codec& c : list) {
        Row& row = rows[c.name];
        std::vector<double> enc, pass, dec;
        GlbStats stats;
        std::vector<std::uint8_t> glb;
        for (int r = 0; r < runs; ++r) {
          enc.push_back(cpu_ms([&] { glb = std::move(*encode_glb(scene, c.options, &stats)); }));
          auto chunks = glb::parse_glb(glb.data(), glb.size());
          pass.push_back(cpu_ms([&] {
            if (c.options.geometry_codec == GeometryCodec::kDraco)
              (void)glb::draco_decompress(*chunks, GlbDecodeLimits{});
            else
              (void)glb::meshopt_decompress(*chunks);
          }));
          dec.push_back(cpu_ms([&] { (void)decode_glb(glb.data(), glb.size()); }));
        }
        row.geometry.push_back(double(stats.geometry_bytes));
        row.per_triangle.push_back(stats.geometry_bytes / triangles);
        row.encode_ms.push_back(median(enc));
        row.pass_ms.push_back(median(pass));
        row.decode_ms.push_back(median(dec));
      }
    }
  }
  std::printf(
      "A. The same realtime mesh per codec: %d frames (TUM fr1/xyz + ICL), medians over frames of the median "
      "of %d runs\n\n",
      frames, runs);
  std::printf("| codec | geometry B | B/triangle | encode_glb CPU ms | geometry decode CPU ms | decode_glb CPU ms |\n");
  std::printf("|---|---|---|---|---|---|\n");
  for (const Codec& c : list) {
    const Row& r = rows[c.name];
    std::printf("| %s | %.0f | %.2f | %.2f | %.2f | %.2f |\n", c.name.c_str(), median(r.geometry),
                median(r.per_triangle), median(r.encode_ms), median(r.pass_ms), median(r.decode_ms));
  }
  std::printf(
      "\nB. The realtime reduction at its 40 kB budget, per codec (frame -> GLB bytes, budget loop included)\n\n");
  std::printf(
      "| codec | GLB B median | GLB B max | triangles median | over-budget frames | frame -> GLB CPU ms | wall ms |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  for (const char* name : {"meshopt", "draco"}) {
    const Budget& b = budget[name];
    std::printf("| %s | %.0f | %.0f | %.0f | %d of %d | %.1f | %.1f |\n", name, median(b.bytes), quantile(b.bytes, 1.0),
                median(b.triangles), b.over, frames, median(b.cpu), median(b.ms));
  }
  return 0;
}
