// transmission_bench: for one RGB-D frame, what a robot could send and how well the receiver sees the scene.
// Representations (bench/transmission/codecs.h): raw float cloud, JPEG + 16-bit PNG (as a cloud, and meshed on the
// receiver), Draco point cloud (11 and 14 bit positions), rgbdcast GLB (atlas and frame texture). For each: bytes,
// encode and decode ms (medians of --runs runs), and fidelity of the DECODED payload rendered at the capture pose
// and at real novel poses (bench/transmission/datasets.h), compared with the real colour images (compare_views).
// Clouds are drawn as splats of 1, 2 and 3 px; the summary shows the size with the best PSNR (chosen separately
// for the capture pose and for the novel views); the detail table shows every size.
// Usage: transmission_bench [--runs N] [--backend auto|vulkan|osmesa] [--data DIR] [--only icl|tum]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <vector>

#include "bench/bench_stats.h"
#include "bench/transmission/codecs.h"
#include "bench/transmission/datasets.h"
#include "bench/transmission/fidelity.h"
#include "renderer/create_renderer.h"

using namespace rgbdcast;
using namespace rgbdcast::bench;

namespace {

struct Args {
  int runs = 5;
  BackendChoice backend = BackendChoice::kAuto;
  std::string data_dir = RGBDCAST_DATA_DIR;
  std::string only;
};

struct Candidate {
  std::string name;
  std::function<Result<Bytes>()> encode;
  std::function<Result<Scene>(const Bytes&)> decode;
};

// One point size (or the mesh) and what it gave.
struct Drawn {
  RenderOptions options;
  ViewSetFidelity fidelity;
  std::vector<Image> renders;  // one per view
  std::string label() const {
    return options.mode == RenderMode::kMesh ? "mesh" : "splat " + std::to_string(int(options.point_size_px)) + "px";
  }
};

struct Measured {
  std::string name;
  size_t bytes = 0;
  double encode_ms = 0, decode_ms = 0;
  std::string contents;  // what the receiver got
  std::vector<Drawn> drawn;
  // Over the pixels that every row's summary draw covers (and that had depth): capture, then the novel mean.
  double common_capture_psnr_db = 0, common_capture_ssim = 0, common_novel_psnr_db = 0, common_novel_ssim = 0;
};

[[noreturn]] void die(const std::string& what, const Error& e) {
  std::fprintf(stderr, "transmission_bench: %s: %s\n", what.c_str(), e.message.c_str());
  std::exit(1);
}

std::string contents_of(const Scene& scene) {
  size_t points = 0, triangles = 0;
  for (const auto& n : scene.nodes) {
    points += n.points.size();
    triangles += n.mesh.triangle_count();
  }
  char buf[64];
  if (triangles)
    std::snprintf(buf, sizeof buf, "%zu tris", triangles);
  else
    std::snprintf(buf, sizeof buf, "%zu pts", points);
  return buf;
}

// Sender-side stage times of the rgbdcast rows, by row name.
using StageLog = std::vector<std::pair<std::string, std::vector<RgbdcastStageMs>>>;

Candidate rgbdcast_candidate(const std::string& name, const RgbdFrame& frame, TextureMode mode,
                             const ReductionParams& params, StageLog* log) {
  log->push_back({name, {}});
  const size_t slot = log->size() - 1;
  return {name,
          [&frame, mode, params, log, slot] {
            RgbdcastStageMs st;
            auto r = encode_rgbdcast(frame, mode, &st, params);
            (*log)[slot].second.push_back(st);
            return r;
          },
          decode_rgbdcast};
}

std::vector<Candidate> candidates_for(const RgbdFrame& frame, StageLog* log) {
  const Intrinsics k = frame.intrinsics;
  std::vector<Candidate> c;
  c.push_back({"raw cloud (float xyz+rgb)", [&frame] { return Result<Bytes>(encode_raw_cloud(frame)); },
               [k](const Bytes& b) { return decode_raw_cloud(b, k); }});
  for (int q : {90, 75}) {
    c.push_back({"jpeg" + std::to_string(q) + "+png16 -> cloud", [&frame, q] { return encode_jpeg_png(frame, q); },
                 [k](const Bytes& b) { return decode_jpeg_png_cloud(b, k); }});
    c.push_back({"jpeg" + std::to_string(q) + "+png16 -> grid mesh", [&frame, q] { return encode_jpeg_png(frame, q); },
                 [k](const Bytes& b) { return decode_jpeg_png_grid_mesh(b, k); }});
  }
  for (int bits : {11, 14})
    c.push_back({"draco cloud q" + std::to_string(bits), [&frame, bits] { return encode_draco(frame, bits); },
                 [k](const Bytes& b) { return decode_draco(b, k); }});
  const ReductionParams defaults;
  c.push_back(rgbdcast_candidate("rgbdcast glb atlas", frame, TextureMode::kAtlas, defaults, log));
  c.push_back(rgbdcast_candidate("rgbdcast glb frame-tex", frame, TextureMode::kFrame, defaults, log));
  // What `rgbdcast reduce` does by default: the atlas or the frame texture, chosen per frame.
  c.push_back(rgbdcast_candidate("rgbdcast glb auto-tex", frame, TextureMode::kAuto, defaults, log));
  // Not the default: the organized outlier filter (the project's fast option), to show where the encode time goes.
  ReductionParams organized;
  organized.outlier_method = OutlierMethod::kOrganized;
  c.push_back(
      rgbdcast_candidate("rgbdcast glb atlas, organized outliers*", frame, TextureMode::kAtlas, organized, log));
  c.push_back(
      rgbdcast_candidate("rgbdcast glb frame-tex, organized outliers*", frame, TextureMode::kFrame, organized, log));
  return c;
}

Measured measure(const Candidate& c, const std::vector<ReferenceView>& views, Renderer& renderer, int runs) {
  Measured m;
  m.name = c.name;
  Bytes bytes;
  std::vector<double> enc, dec;
  for (int r = 0; r < runs; ++r) {
    Result<Bytes> out = make_error(ErrorCode::kInternal, "not run");
    enc.push_back(time_ms([&] { out = c.encode(); }));
    if (!out) die(c.name + " encode", out.error());
    bytes = std::move(*out);
  }
  Scene received;
  for (int r = 0; r < runs; ++r) {
    Result<Scene> out = make_error(ErrorCode::kInternal, "not run");
    dec.push_back(time_ms([&] { out = c.decode(bytes); }));
    if (!out) die(c.name + " decode", out.error());
    received = std::move(*out);
  }
  m.bytes = bytes.size();
  m.encode_ms = median(enc);
  m.decode_ms = median(dec);
  m.contents = contents_of(received);
  auto id = renderer.upload(received);
  if (!id) die(c.name + " upload", id.error());
  std::vector<RenderOptions> draws;
  if (received.triangle_count() > 0) {
    draws.push_back(RenderOptions{});
  } else {
    for (float px : {1.0f, 2.0f, 3.0f}) {
      RenderOptions o;
      o.mode = RenderMode::kPoints;
      o.point_size_px = px;
      draws.push_back(o);
    }
  }
  for (const RenderOptions& o : draws) {
    std::vector<Image> renders;
    auto f = measure_views(renderer, *id, o, views, &renders);
    if (!f) die(c.name + " render", f.error());
    m.drawn.push_back({o, *f, std::move(renders)});
  }
  renderer.release(*id);
  return m;
}

const Drawn& best_capture(const Measured& m) {
  return *std::max_element(m.drawn.begin(), m.drawn.end(), [](const Drawn& a, const Drawn& b) {
    return a.fidelity.capture.psnr_db < b.fidelity.capture.psnr_db;
  });
}

const Drawn& best_novel(const Measured& m) {
  return *std::max_element(m.drawn.begin(), m.drawn.end(), [](const Drawn& a, const Drawn& b) {
    return a.fidelity.novel_psnr_db < b.fidelity.novel_psnr_db;
  });
}

// PSNR/SSIM of every row over the pixels all rows cover (each row drawn as in the summary: its best-PSNR draw for
// the capture pose, and for the novel views), so that a representation that covers less is not judged on easier
// pixels only.
void measure_common_pixels(std::vector<Measured>& rows, const std::vector<ReferenceView>& views) {
  for (size_t i = 0; i < views.size(); ++i) {
    std::vector<const Image*> renders;
    for (const Measured& m : rows) renders.push_back(&(i == 0 ? best_capture(m) : best_novel(m)).renders[i]);
    const cv::Mat mask = common_pixels(views[i], renders);
    for (size_t r = 0; r < rows.size(); ++r) {
      auto f = compare_views(views[i].color_rgb, *renders[r], mask);
      if (!f) die("common pixels, " + views[i].name, f.error());
      if (i == 0) {
        rows[r].common_capture_psnr_db = f->psnr_db;
        rows[r].common_capture_ssim = f->ssim;
      } else {
        rows[r].common_novel_psnr_db += f->psnr_db / double(views.size() - 1);
        rows[r].common_novel_ssim += f->ssim / double(views.size() - 1);
      }
    }
    if (!rows.empty())
      std::printf("common pixels, %s: %d of %d valid\n", views[i].name.c_str(), cv::countNonZero(mask),
                  cv::countNonZero(views[i].valid));
  }
}

void print_summary(const std::vector<Measured>& rows, size_t raw_bytes, const RgbdFrame& frame, bool has_novel) {
  std::printf(
      "\n| representation | bytes | raw/bytes | encode ms | decode ms | receiver gets | capture: draw | PSNR dB | "
      "SSIM | coverage | all-valid PSNR / SSIM | common PSNR / SSIM | novel: draw | mean PSNR dB | mean SSIM | "
      "mean coverage | all-valid PSNR / SSIM | common PSNR / SSIM |\n");
  std::printf("|---|--:|--:|--:|--:|--:|---|--:|--:|--:|--:|--:|---|--:|--:|--:|--:|--:|\n");
  for (const Measured& m : rows) {
    const Drawn& c = best_capture(m);
    const Drawn& n = best_novel(m);
    const ViewFidelity& cap = c.fidelity.capture;
    std::printf("| %s | %zu | %.1fx | %.1f | %.1f | %s | %s | %.2f | %.3f | %.3f | %.2f / %.3f | %.2f / %.3f |",
                m.name.c_str(), m.bytes, double(raw_bytes) / m.bytes, m.encode_ms, m.decode_ms, m.contents.c_str(),
                c.label().c_str(), cap.psnr_db, cap.ssim, cap.coverage, cap.psnr_valid_db, cap.ssim_valid,
                m.common_capture_psnr_db, m.common_capture_ssim);
    const ViewSetFidelity& nov = n.fidelity;
    if (has_novel)
      std::printf(" %s | %.2f | %.3f | %.3f | %.2f / %.3f | %.2f / %.3f |\n", n.label().c_str(), nov.novel_psnr_db,
                  nov.novel_ssim, nov.novel_coverage, nov.novel_psnr_valid_db, nov.novel_ssim_valid,
                  m.common_novel_psnr_db, m.common_novel_ssim);
    else
      std::printf(" - | - | - | - | - | - |\n");
  }
  const size_t organized = static_cast<size_t>(frame.intrinsics.width) * frame.intrinsics.height * 15;
  std::printf(
      "| raw organized cloud (%dx%d x 15 B, NaN where no depth) | %zu | %.1fx | - | - | as raw cloud | | | | | | | | | "
      "| | | |\n",
      frame.intrinsics.width, frame.intrinsics.height, organized, double(raw_bytes) / organized);
}

void print_detail(const std::vector<Measured>& rows, const std::vector<ReferenceView>& views) {
  std::printf(
      "\nEvery draw (PSNR dB / coverage per view; novel mean also all-valid PSNR, holes black):\n"
      "| representation | draw | capture |");
  for (size_t i = 1; i < views.size(); ++i) std::printf(" %s |", views[i].name.c_str());
  std::printf(" novel mean | novel all-valid PSNR |\n|---|---|--:|");
  for (size_t i = 1; i < views.size(); ++i) std::printf("--:|");
  std::printf("--:|--:|\n");
  for (const Measured& m : rows)
    for (const Drawn& d : m.drawn) {
      const auto& f = d.fidelity;
      std::printf("| %s | %s | %.2f / %.3f |", m.name.c_str(), d.label().c_str(), f.capture.psnr_db,
                  f.capture.coverage);
      for (const ViewFidelity& v : f.novel) std::printf(" %.2f / %.3f |", v.psnr_db, v.coverage);
      std::printf(" %.2f / %.3f | %.2f |\n", f.novel_psnr_db, f.novel_coverage, f.novel_psnr_valid_db);
    }
}

void print_stages(const char* name, const std::vector<RgbdcastStageMs>& stages) {
  std::vector<double> r, t, g;
  for (const auto& s : stages) {
    r.push_back(s.reduce_ms);
    t.push_back(s.texture_ms);
    g.push_back(s.glb_ms);
  }
  std::printf("%s encode, medians: reduce_frame %.1f ms, build_atlas %.1f ms, encode_glb %.1f ms\n", name, median(r),
              median(t), median(g));
}

// Is the novel pose right? The raw cloud drawn at each novel view's pose, and at the capture pose (as if the camera
// had not moved), compared with that view's real image: a correct pose should do clearly better than no motion.
void print_pose_check(const TestCase& tc, Renderer& renderer) {
  if (tc.views.size() < 2) return;
  auto scene = decode_raw_cloud(encode_raw_cloud(tc.sent), tc.sent.intrinsics);
  if (!scene) die("pose check", scene.error());
  auto id = renderer.upload(*scene);
  if (!id) die("pose check upload", id.error());
  RenderOptions o;
  o.mode = RenderMode::kPoints;
  o.point_size_px = 2.0f;
  std::printf("pose check (raw cloud, splat 2px, PSNR dB / coverage vs the real frame):\n");
  for (size_t i = 1; i < tc.views.size(); ++i) {
    ReferenceView still = tc.views[i];
    still.camera.camera_to_world.setIdentity();
    auto at_pose = measure_views(renderer, *id, o, {tc.views[0], tc.views[i]});
    auto no_motion = measure_views(renderer, *id, o, {tc.views[0], still});
    if (!at_pose || !no_motion) die("pose check render", at_pose ? no_motion.error() : at_pose.error());
    std::printf("  %s: at its pose %.2f / %.3f; at the capture pose (no motion) %.2f / %.3f\n",
                tc.views[i].name.c_str(), at_pose->novel[0].psnr_db, at_pose->novel[0].coverage,
                no_motion->novel[0].psnr_db, no_motion->novel[0].coverage);
  }
  renderer.release(*id);
}

void run_case(const TestCase& tc, Renderer& renderer, int runs) {
  std::printf("\n## %s\nfolder %s, sent frame 0 (%s), %dx%d, fx %.1f fy %.1f cx %.1f cy %.1f; %zu novel view(s)\n",
              tc.name.c_str(), tc.folder.c_str(), tc.sent.color_path.c_str(), tc.sent.intrinsics.width,
              tc.sent.intrinsics.height, tc.sent.intrinsics.fx, tc.sent.intrinsics.fy, tc.sent.intrinsics.cx,
              tc.sent.intrinsics.cy, tc.views.size() - 1);
  for (const std::string& n : tc.notes) std::printf("  %s\n", n.c_str());
  print_pose_check(tc, renderer);
  std::fflush(stdout);
  StageLog stages;
  std::vector<Measured> rows;
  for (const Candidate& c : candidates_for(tc.sent, &stages)) {
    rows.push_back(measure(c, tc.views, renderer, runs));
    std::fprintf(stderr, "  measured %s\n", c.name.c_str());
  }
  const size_t raw_bytes = rows.front().bytes;
  std::printf("\n");
  measure_common_pixels(rows, tc.views);
  print_summary(rows, raw_bytes, tc.sent, tc.views.size() > 1);
  print_detail(rows, tc.views);
  std::printf("\n");
  for (const auto& [name, log] : stages) print_stages(name.c_str(), log);
  std::printf(
      "* not the default ReductionParams: outlier_method = organized (pixel-window neighbours), the rest default\n");
  std::fflush(stdout);
}

Args parse_args(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string s = argv[i];
    const bool has_value = i + 1 < argc;
    if (s == "--runs" && has_value)
      a.runs = std::max(1, std::atoi(argv[++i]));
    else if (s == "--data" && has_value)
      a.data_dir = argv[++i];
    else if (s == "--only" && has_value)
      a.only = argv[++i];
    else if (s == "--backend" && has_value) {
      auto b = parse_backend_choice(argv[++i]);
      if (!b) die("--backend", b.error());
      a.backend = *b;
    } else {
      std::fprintf(
          stderr,
          "usage: transmission_bench [--runs N] [--backend auto|vulkan|osmesa] [--data DIR] [--only icl|tum]\n");
      std::exit(2);
    }
  }
  return a;
}

}  // namespace

int main(int argc, char** argv) {
  const Args args = parse_args(argc, argv);
  auto selection = create_renderer(args.backend);
  if (!selection) die("renderer", selection.error());
  Renderer& renderer = *selection->renderer;
  std::printf("# transmission_bench: renderer %s (%s), %d runs per timing (median)\n", renderer.backend().c_str(),
              renderer.device().c_str(), args.runs);
  std::printf(
      "bytes: the whole payload; raw/bytes: raw valid cloud bytes / payload bytes; PSNR and SSIM over pixels "
      "that are covered and had valid depth in that view's real frame; all-valid: over every valid pixel, holes "
      "black (what the operator sees); common: over the valid pixels every row's draw covers; novel = mean over "
      "the novel views\n");
  if (args.only.empty() || args.only == "icl") {
    auto icl = load_icl_case(args.data_dir);
    if (!icl) die("ICL case", icl.error());
    run_case(*icl, renderer, args.runs);
  }
  if (args.only.empty() || args.only == "tum") {
    auto tum = load_tum_case(args.data_dir);
    if (!tum) die("TUM case", tum.error());
    run_case(*tum, renderer, args.runs);
  }
  return 0;
}
