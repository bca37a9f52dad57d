// realtime_bench: the realtime preset beside the paper preset and beside what a robotics engineer sends today
// (JPEG + 16-bit PNG depth), in one run, on the shared real captures.
//  A. Speed and size: per frame, the wall time from the decoded images in memory (undistortion included) to the GLB
//     bytes, through the one frame -> scene function (pipeline/frame_scene.h) and encode_glb; medians over frames
//     and runs (a set's frames back to back, as a live stream, --runs times over, so that caches hold what a
//     stream's would, not one frame's repeated runs). The paper preset is timed on the
//     first --paper-frames frames of each set in the same run, after the realtime frames. Fidelity
//     of the DECODED GLB at the capture pose: coverage of the valid pixels, PSNR over the pixels drawn, PSNR over all
//     valid pixels with holes black (evaluation/image_metrics.h).
//  B. Rate-distortion at budgets of 10-160 kB, capture pose and novel views at ground-truth poses (augmented ICL
//     frames 1-4 from frame 0; TUM fr1/xyz 200-319 frames 5, 10, 15, 20 from frame 0; ICL-NUIM frames 1-4 from
//     frame 0: every shared sequence with ground truth), against JPEG-q + PNG16
//     (full, half and quarter resolution depth, meshed on the receiver), Draco colour clouds (2 px splats) and the
//     paper preset.
// Usage: realtime_bench [--runs N] [--frames N] [--paper-frames N] [--backend auto|vulkan|osmesa] [--data DIR]
//                       [--only speed|rd|budget]
//  C. (--only budget) The default budget, min(40 kB, a quarter of the frame's JPEG90+PNG16 payload), on every
//     frame: payload, budget, the GLB `rgbdcast reduce` writes at it and at 40 kB, and the estimate's cost.
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <vector>

#include "base/malloc_settings.h"
#include "bench/bench_stats.h"
#include "bench/transmission/codecs.h"
#include "bench/transmission/datasets.h"
#include "bench/transmission/fidelity.h"
#include "gltf/gltf_io.h"
#include "input/frame_source.h"
#include "pipeline/frame_defaults.h"
#include "pipeline/frame_scene.h"
#include "renderer/create_renderer.h"

using namespace rgbdcast;
using namespace rgbdcast::bench;

namespace {

struct Args {
  int runs = 3, frames = 30, paper_frames = 2;
  BackendChoice backend = BackendChoice::kAuto;
  std::string data_dir = RGBDCAST_DATA_DIR;
  std::string only;
};

double min_of(const std::vector<double>& v) { return v.empty() ? 0 : *std::min_element(v.begin(), v.end()); }
double max_of(const std::vector<double>& v) { return v.empty() ? 0 : *std::max_element(v.begin(), v.end()); }

[[noreturn]] void die(const std::string& what, const Error& e) {
  std::fprintf(stderr, "realtime_bench: %s: %s\n", what.c_str(), e.message.c_str());
  std::exit(1);
}

FrameReductionOptions realtime_options(double budget_kb, double geometry_share = 0.45) {
  FrameReductionOptions o;
  o.params = reduction_preset(Preset::kRealtime);
  o.glb.geometry_codec = default_geometry_codec(Preset::kRealtime);  // as `rgbdcast reduce` (app/reduce_common.cpp)
  o.budget_kb = budget_kb;
  o.budget_geometry_share = geometry_share;
  return o;
}
FrameReductionOptions paper_options() {
  FrameReductionOptions o;
  o.params = reduction_preset(Preset::kPaper);
  return o;
}

// frame -> GLB bytes, as `rgbdcast reduce` does it.
Result<Bytes> encode(const RgbdFrame& frame, const FrameReductionOptions& o) {
  auto textured = reduce_and_texture(frame, o);
  if (!textured) return textured.error();
  const GlbWriteOptions glb = write_options(*textured, o.glb);
  return encode_glb(frame_scene(std::move(*textured), ""), glb);
}

// One frame as it comes off the sensor: decoded images in memory, not yet undistorted.
struct RawFrame {
  cv::Mat color_rgb, depth_raw;
  Intrinsics intrinsics;
  RgbdFrame ready;  // the source's own frame (PCD sources: timed from here, they need no undistortion)
  bool from_images = false;
};

// The frame as a source would give it, undistorted through the set's tables (a source keeps them for its camera).
Result<RgbdFrame> prepare(const RawFrame& raw, Undistorter& undistorter) {
  if (!raw.from_images) return raw.ready;
  return make_frame(raw.color_rgb, raw.depth_raw, raw.intrinsics, &undistorter);
}

struct Dataset {
  std::string name;
  std::vector<std::string> paths;  // folders, .pcd files, or "colour.png|depth.png" pairs
  std::string intrinsics;
  int max_frames;
};

Result<std::vector<RawFrame>> load_raw_source(const std::string& input, const SourceOptions& o, int max_frames) {
  auto source = open_frame_source(input, o);
  if (!source) return source.error();
  std::vector<RawFrame> out;
  for (size_t i = 0; i < (*source)->size() && static_cast<int>(i) < max_frames; ++i) {
    RawFrame r;
    auto f = (*source)->frame(i);
    if (!f) return f.error();
    r.ready = std::move(*f);
    r.intrinsics = (*source)->intrinsics();
    if ((*source)->kind() != "pcd") {
      const FrameEntry& e = (*source)->entries()[i];
      cv::Mat bgr = cv::imread(e.color_path, cv::IMREAD_COLOR);
      r.depth_raw = cv::imread(e.depth_path, cv::IMREAD_UNCHANGED);
      if (!bgr.empty() && r.depth_raw.type() == CV_16UC1) {
        cv::cvtColor(bgr, r.color_rgb, cv::COLOR_BGR2RGB);
        r.from_images = true;
      }
    }
    out.push_back(std::move(r));
  }
  return out;
}

Result<std::vector<RawFrame>> load_raw(const std::string& data, const Dataset& d) {
  std::vector<RawFrame> out;
  for (const std::string& path : d.paths) {
    SourceOptions o;
    o.intrinsics = d.intrinsics;
    std::string input = data + path;
    if (const auto bar = path.find('|'); bar != std::string::npos) {
      input = data + path.substr(0, bar);
      o.depth_path = data + path.substr(bar + 1);
    }
    auto more = load_raw_source(input, o, d.max_frames);
    if (!more) return more.error();
    for (auto& f : *more) out.push_back(std::move(f));
  }
  return out;
}

struct Fidelity {
  double coverage = 0, psnr = 0, psnr_valid = 0;
};

Result<Fidelity> capture_fidelity(Renderer& renderer, const Scene& scene, const RgbdFrame& frame,
                                  const RenderOptions& options = {}) {
  auto id = renderer.upload(scene);
  if (!id) return id.error();
  CaptureCamera cam;
  cam.intrinsics = frame.intrinsics.pinhole();
  auto r = renderer.render(*id, ViewCamera::from_capture(cam), options);
  renderer.release(*id);
  if (!r) return r.error();
  auto f = compare_views(frame.color_rgb, r->color, frame.depth_m > 0);
  if (!f) return f.error();
  return Fidelity{f->coverage, f->psnr_db, f->psnr_valid_db};
}

// The shared captures, as sets; of the 120-frame excerpt, the first `frames`.
std::vector<Dataset> shared_sets(int frames) {
  return {
      {"TUM fr1/xyz 200-319", {"/tum/rgbd_dataset_freiburg1_xyz_200_319"}, "fr1", frames},
      {"TUM fr1/xyz 0-2", {"/tum/rgbd_dataset_freiburg1_xyz"}, "fr1", 3},
      {"TUM fr3 office", {"/tum/rgbd_dataset_freiburg3_long_office_household"}, "fr3", 2},
      {"TUM fr2 desk pair",
       {"/tum/freiburg2_desk_pair/1.png|/tum/freiburg2_desk_pair/1_depth.png",
        "/tum/freiburg2_desk_pair/2.png|/tum/freiburg2_desk_pair/2_depth.png"},
       "fr2",
       1},
      {"augmented ICL", {"/augmented_icl_livingroom"}, "", 5},
      {"ICL-NUIM", {"/icl_nuim_livingroom"}, "", 5},
      {"PCL Kinect PCD",
       {"/pcl_kinect_organized/pcd/frame_20121214T142255.814212.pcd",
        "/pcl_kinect_organized/pcd/frame_20121214T142256.068683.pcd",
        "/pcl_kinect_organized/pcd/frame_20121214T142256.332395.pcd"},
       "kinect",
       1},
  };
}

void speed_section(const Args& args, Renderer& renderer) {
  const std::vector<Dataset> sets = shared_sets(args.frames);
  std::printf("\n## A. Speed, size and capture-pose fidelity (realtime preset at its default 40 kB budget)\n");
  std::printf(
      "wall ms from decoded images (undistortion included) to GLB bytes; realtime: median (p90) over frames x "
      "%d runs (the frames back to back, run after run); paper: median over its first %d frames, 1 run each, "
      "after them\n\n",
      args.runs, args.paper_frames);
  std::printf(
      "| set | frames | realtime ms | paper ms | paper/realtime | realtime kB (max) | paper kB | JPEG90+PNG16 kB | "
      "triangles (max) | coverage min / median | PSNR drawn dB (min) | PSNR all valid dB (min) | grid mesh coverage / "
      "all-valid dB | paper coverage / all-valid dB |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Dataset& d : sets) {
    auto raw = load_raw(args.data_dir, d);
    Undistorter undistorter;
    if (!raw) {
      std::printf("| %s | skipped: %s |\n", d.name.c_str(), raw.error().message.c_str());
      continue;
    }
    std::vector<double> rt_ms, paper_ms, rt_kb, paper_kb, jp_kb, tris, cov, psnr, psnr_valid, grid_cov, grid_pv,
        paper_cov, paper_pv;
    // The realtime preset's timing: the set's frames one after another, as a live stream reduces them, --runs
    // times over; nothing else runs between them (the fidelity renders and the paper preset come after, so that
    // their memory and caches are not charged to the next frame).
    std::vector<Bytes> glbs(raw->size());
    for (int run = 0; run < args.runs; ++run)
      for (size_t i = 0; i < raw->size(); ++i) {
        Result<Bytes> out = make_error(ErrorCode::kInternal, "not run");
        rt_ms.push_back(time_ms([&] {
          auto frame = prepare((*raw)[i], undistorter);
          out = frame ? encode(*frame, realtime_options(40)) : Result<Bytes>(frame.error());
        }));
        if (!out) die(d.name + " frame " + std::to_string(i), out.error());
        glbs[i] = std::move(*out);
      }
    for (size_t i = 0; i < raw->size(); ++i) {
      const Bytes& glb = glbs[i];
      auto frame = prepare((*raw)[i], undistorter);
      if (!frame) die(d.name, frame.error());
      rt_kb.push_back(glb.size() / 1000.0);
      auto scene = decode_glb(glb.data(), glb.size());
      if (!scene) die("decode", scene.error());
      tris.push_back(static_cast<double>(scene->triangle_count()));
      auto f = capture_fidelity(renderer, *scene, *frame);
      if (!f) die("render", f.error());
      cov.push_back(f->coverage);
      psnr.push_back(f->psnr);
      psnr_valid.push_back(f->psnr_valid);
      auto jp = encode_jpeg_png(*frame, 90);
      if (!jp) die("jpeg+png", jp.error());
      jp_kb.push_back(jp->size() / 1000.0);
      auto grid = decode_jpeg_png_grid_mesh(*jp, frame->intrinsics.pinhole());
      if (!grid) die("grid mesh", grid.error());
      auto gf = capture_fidelity(renderer, *grid, *frame);
      if (!gf) die("render grid", gf.error());
      grid_cov.push_back(gf->coverage);
      grid_pv.push_back(gf->psnr_valid);
      if (static_cast<int>(i) < args.paper_frames) {
        Result<Bytes> out = make_error(ErrorCode::kInternal, "not run");
        paper_ms.push_back(time_ms([&] {
          auto pf = prepare((*raw)[i], undistorter);
          out = pf ? encode(*pf, paper_options()) : Result<Bytes>(pf.error());
        }));
        if (!out) die(d.name + " paper", out.error());
        paper_kb.push_back(out->size() / 1000.0);
        auto ps = decode_glb(out->data(), out->size());
        if (!ps) die("decode paper", ps.error());
        auto pf = capture_fidelity(renderer, *ps, *frame);
        if (!pf) die("render paper", pf.error());
        paper_cov.push_back(pf->coverage);
        paper_pv.push_back(pf->psnr_valid);
      }
    }
    std::printf(
        "| %s | %zu | %.1f (%.1f) | %.0f | %.0fx | %.1f (%.1f) | %.1f | %.1f | %.0f (%.0f) | %.4f / %.4f | %.2f (%.2f) "
        "| "
        "%.2f (%.2f) | %.4f / %.2f | %.4f / %.2f |\n",
        d.name.c_str(), raw->size(), median(rt_ms), quantile(rt_ms, 0.9), median(paper_ms),
        median(paper_ms) / std::max(1e-9, median(rt_ms)), median(rt_kb), max_of(rt_kb), median(paper_kb), median(jp_kb),
        median(tris), max_of(tris), min_of(cov), median(cov), median(psnr), min_of(psnr), median(psnr_valid),
        min_of(psnr_valid), median(grid_cov), median(grid_pv), median(paper_cov), median(paper_pv));
    std::fflush(stdout);
  }
}

struct Row {
  std::string name;
  size_t bytes = 0;
  ViewSetFidelity f;
};

void rd_case(const TestCase& tc, Renderer& renderer) {
  std::printf("\n### %s: %zu novel views\n", tc.name.c_str(), tc.views.size() - 1);
  for (const auto& n : tc.notes) std::printf("- %s\n", n.c_str());
  std::printf(
      "\n| what | bytes | capture coverage | capture PSNR drawn | capture PSNR all valid | novel coverage | "
      "novel PSNR drawn | novel PSNR all valid |\n|---|---|---|---|---|---|---|---|\n");
  auto row = [&](const std::string& name, const Result<Bytes>& bytes,
                 const std::function<Result<Scene>(const Bytes&)>& decode, const RenderOptions& ro) {
    if (!bytes) {
      std::printf("| %s | failed: %s |\n", name.c_str(), bytes.error().message.c_str());
      return;
    }
    auto scene = decode(*bytes);
    if (!scene) die(name + " decode", scene.error());
    auto id = renderer.upload(*scene);
    if (!id) die(name + " upload", id.error());
    auto f = measure_views(renderer, *id, ro, tc.views);
    renderer.release(*id);
    if (!f) die(name + " views", f.error());
    std::printf("| %s | %zu | %.4f | %.2f | %.2f | %.4f | %.2f | %.2f |\n", name.c_str(), bytes->size(),
                f->capture.coverage, f->capture.psnr_db, f->capture.psnr_valid_db, f->novel_coverage, f->novel_psnr_db,
                f->novel_psnr_valid_db);
    std::fflush(stdout);
  };
  const Intrinsics k = tc.sent.intrinsics.pinhole();
  auto glb_decode = [](const Bytes& b) { return decode_glb(b.data(), b.size()); };
  const RenderOptions mesh;
  RenderOptions splat2;
  splat2.mode = RenderMode::kPoints;
  splat2.point_size_px = 2;
  for (double kb : {10.0, 20.0, 40.0, 80.0, 160.0})
    row("rgbdcast realtime, budget " + std::to_string(int(kb)) + " kB", encode(tc.sent, realtime_options(kb)),
        glb_decode, mesh);
  for (double share : {0.3, 0.6, 0.75})
    row("rgbdcast realtime, budget 40 kB, geometry share " + std::to_string(share).substr(0, 4),
        encode(tc.sent, realtime_options(40, share)), glb_decode, mesh);
  // The geometry's Draco position step and the texture scale the outline is kept for (the budget then tries the
  // texture there before it halves it): spent on the outline, which the novel views see.
  for (double outline_scale : {1.0, 0.75}) {
    FrameReductionOptions o = realtime_options(40);
    o.glb.position_quantum_m = 0.002;
    o.budget_outline_texture_scale = outline_scale;
    row("rgbdcast realtime, budget 40 kB, positions 2 mm" +
            std::string(outline_scale < 1 ? ", outline scale 0.75" : ""),
        encode(tc.sent, o), glb_decode, mesh);
  }
  // The packed upper-triangle atlas (cells sized to each triangle's image footprint, the design card's shape)
  // against the frame texture the preset defaults to, under the same budgets.
  for (double kb : {20.0, 40.0, 80.0, 160.0}) {
    FrameReductionOptions o = realtime_options(kb);
    o.texture = TextureMode::kFootprint;
    row("rgbdcast realtime, budget " + std::to_string(int(kb)) + " kB, footprint atlas", encode(tc.sent, o), glb_decode,
        mesh);
  }
  row("rgbdcast realtime, no budget (tolerance 2 sigma, q85)", encode(tc.sent, realtime_options(0)), glb_decode, mesh);
  row("rgbdcast paper preset", encode(tc.sent, paper_options()), glb_decode, mesh);
  for (int step : {1, 2, 4})
    for (int q : {10, 30, 50, 70, 90}) {
      const std::string depth = step == 1 ? "PNG16" : "PNG16 at 1/" + std::to_string(step);
      row(
          "JPEG q" + std::to_string(q) + " + " + depth + " (grid mesh)", encode_jpeg_png(tc.sent, q, step),
          [&](const Bytes& b) { return decode_jpeg_png_grid_mesh(b, k); }, mesh);
    }
  for (int qp : {8, 11, 14})
    row(
        "Draco colour cloud qp" + std::to_string(qp) + " (2 px splats)", encode_draco(tc.sent, qp),
        [&](const Bytes& b) { return decode_draco(b, k); }, splat2);
  row(
      "full cloud, raw floats (2 px splats)", Result<Bytes>(encode_raw_cloud(tc.sent)),
      [&](const Bytes& b) { return decode_raw_cloud(b, k); }, splat2);
}

// C. The default budget (pipeline/frame_defaults.h): min(40 kB, a quarter of the frame's JPEG90+PNG16 payload), on
// every frame of every set, with what `rgbdcast reduce` then writes (realtime, Draco) and what the estimate costs.
void budget_section(const Args& args) {
  std::printf("\n## C. The default budget: min(40 kB, a quarter of the frame's JPEG90+PNG16 payload)\n");
  std::printf(
      "per set: median (min-max) over its frames; estimate ms: default_budget_kb (one JPEG q90 and one PNG16 "
      "encode, on two threads), median over frames x %d runs; reduce ms: frame -> GLB at 40 kB, and at the "
      "default as reduce and the service make it (the estimate inside), "
      "alternating, median over frames x %d runs; same file: the default's GLB is the one at the estimated "
      "budget given explicitly\n\n",
      args.runs, args.runs);
  std::printf(
      "| set | frames | JPEG90+PNG16 kB | a quarter, kB | default budget kB | GLB kB at the default | GLB / payload "
      "(max) | GLB kB at 40 kB | 40 kB GLB / payload (max) | estimate ms | reduce ms at 40 kB | reduce ms at the "
      "default | same file |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Dataset& d : shared_sets(args.frames)) {
    auto raw = load_raw(args.data_dir, d);
    Undistorter undistorter;
    if (!raw) {
      std::printf("| %s | skipped: %s |\n", d.name.c_str(), raw.error().message.c_str());
      continue;
    }
    std::vector<double> payload_kb, quarter_kb, budget_kb, glb_kb, ratio, glb40_kb, ratio40, estimate_ms, at40_ms,
        default_ms;
    bool same_files = true;
    for (const RawFrame& r : *raw) {
      auto frame = prepare(r, undistorter);
      if (!frame) die(d.name, frame.error());
      auto payload = encode_jpeg_png16(*frame, 90);
      if (!payload) die(d.name + " payload", payload.error());
      Result<double> kb = 0.0;
      for (int run = 0; run < args.runs; ++run) estimate_ms.push_back(time_ms([&] { kb = default_budget_kb(*frame); }));
      if (!kb) die(d.name + " budget", kb.error());
      auto glb = encode(*frame, realtime_options(*kb));
      if (!glb) die(d.name + " reduce", glb.error());
      Result<Bytes> glb40 = make_error(ErrorCode::kInternal, "not run"), by_default = glb40;
      FrameReductionOptions default_options = realtime_options(kDefaultBudgetKb);
      default_options.budget_within_payload_share = true;
      for (int run = 0; run < args.runs; ++run) {
        at40_ms.push_back(time_ms([&] { glb40 = encode(*frame, realtime_options(kDefaultBudgetKb)); }));
        default_ms.push_back(time_ms([&] { by_default = encode(*frame, default_options); }));
      }
      if (!glb40) die(d.name + " reduce 40", glb40.error());
      if (!by_default) die(d.name + " reduce at the default", by_default.error());
      same_files = same_files && *by_default == *glb;
      payload_kb.push_back(payload->bytes() / 1000.0);
      quarter_kb.push_back(payload->bytes() / 4000.0);
      budget_kb.push_back(*kb);
      glb_kb.push_back(glb->size() / 1000.0);
      ratio.push_back(static_cast<double>(glb->size()) / payload->bytes());
      glb40_kb.push_back(glb40->size() / 1000.0);
      ratio40.push_back(static_cast<double>(glb40->size()) / payload->bytes());
    }
    auto span = [](const std::vector<double>& v) {
      char b[64];
      std::snprintf(b, sizeof b, "%.1f (%.1f-%.1f)", median(v), min_of(v), max_of(v));
      return std::string(b);
    };
    std::printf("| %s | %zu | %s | %s | %s | %s | %.3f (%.3f) | %s | %.3f (%.3f) | %.1f | %.1f | %.1f | %s |\n",
                d.name.c_str(), raw->size(), span(payload_kb).c_str(), span(quarter_kb).c_str(),
                span(budget_kb).c_str(), span(glb_kb).c_str(), median(ratio), max_of(ratio), span(glb40_kb).c_str(),
                median(ratio40), max_of(ratio40), median(estimate_ms), median(at40_ms), median(default_ms),
                same_files ? "yes" : "NO");
    std::fflush(stdout);
  }
}

}  // namespace

int main(int argc, char** argv) {
  apply_malloc_settings(frame_loop_malloc_settings());  // as `rgbdcast reduce` and `rgbdcast stream` run
  Args args;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "realtime_bench: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--runs")
      args.runs = std::max(1, std::atoi(next().c_str()));
    else if (a == "--frames")
      args.frames = std::max(1, std::atoi(next().c_str()));
    else if (a == "--paper-frames")
      args.paper_frames = std::max(0, std::atoi(next().c_str()));
    else if (a == "--data")
      args.data_dir = next();
    else if (a == "--only")
      args.only = next();
    else if (a == "--backend") {
      auto b = parse_backend_choice(next());
      if (!b) die("--backend", b.error());
      args.backend = *b;
    } else {
      std::fprintf(stderr,
                   "usage: realtime_bench [--runs N] [--frames N] [--paper-frames N] [--backend B] "
                   "[--data DIR] [--only speed|rd|budget]\n");
      return 2;
    }
  }
  auto renderer = create_renderer(args.backend);
  if (!renderer) die("renderer", renderer.error());
  std::printf("realtime_bench: renderer %s (%s)\n", renderer->renderer->backend().c_str(),
              renderer->renderer->device().c_str());
  if (args.only.empty() || args.only == "speed") speed_section(args, *renderer->renderer);
  if (args.only.empty() || args.only == "budget") budget_section(args);
  if (args.only.empty() || args.only == "rd") {
    std::printf("\n## B. Rate-distortion, capture pose and novel views at ground-truth poses\n");
    auto icl = load_icl_case(args.data_dir);
    if (!icl) die("ICL case", icl.error());
    rd_case(*icl, *renderer->renderer);
    auto tum = load_tum_groundtruth_case(args.data_dir, {5, 10, 15, 20});
    if (!tum) die("TUM case", tum.error());
    rd_case(*tum, *renderer->renderer);
    auto icl_nuim = load_icl_nuim_case(args.data_dir);
    if (!icl_nuim) die("ICL-NUIM case", icl_nuim.error());
    rd_case(*icl_nuim, *renderer->renderer);
  }
  return 0;
}
