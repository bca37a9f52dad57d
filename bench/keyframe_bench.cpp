// Frames per second of the keyframe stage (detect + windowed FLANN match + RANSAC, and the optional ICP refinement
// on top) with SIFT, ORB and AKAZE on the real captures. Frames are loaded once; each run processes the sequence in
// order (frame 0: detect only). Prints the median of several runs.
// The tracking table: the whole tracker (keyframes/tracker.h) over the 120-frame TUM fr1/xyz excerpt and augmented
// ICL, the paper's window alone against window + wide + relocalisation, in the same run: frames tracked, relative
// pose error against the ground truth (RMSE and worst pair) and ms per frame for tracking alone (frames preloaded;
// median and p95 over the frames of the median run).
//   keyframe_bench [stages|tracking|all] [runs=7] [FEATURES:METHOD, e.g. orb:live: that tracking row alone]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <string>
#include <vector>

#include "input/frame_source.h"
#include "keyframes/frame_odometry.h"
#include "keyframes/pose_error.h"
#include "keyframes/sequence.h"
#include "keyframes/trajectory_io.h"

using namespace rgbdcast;

namespace {

double now_ms() {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

double cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

struct RunTimes {
  double total_ms = 0, detect_ms = 0, match_ms = 0, ransac_ms = 0, icp_ms = 0;
  int matches = 0, inliers = 0, failed = 0;
};

RunTimes run_once(const std::vector<RgbdFrame>& frames, FeatureType type, bool icp) {
  OdometryParams p;
  p.features.type = type;
  p.refine_icp = icp;
  RunTimes t;
  FrameFeatures prev;
  const double t0 = now_ms();
  for (size_t i = 0; i < frames.size(); ++i) {
    const double d0 = now_ms();
    Result<FrameFeatures> f = detect_features(frames[i], p.features);
    t.detect_ms += now_ms() - d0;
    if (!f) {
      ++t.failed;
      continue;
    }
    if (i > 0) {
      Result<PairEstimate> e = estimate_pair(frames[i - 1], prev, frames[i], *f, p);
      if (e) {
        t.match_ms += e->match_ms;
        t.ransac_ms += e->ransac_ms;
        t.icp_ms += e->icp_ms;
        t.matches += e->matches;
        t.inliers += e->inliers;
      } else {
        ++t.failed;
      }
    }
    prev = std::move(*f);
  }
  t.total_ms = now_ms() - t0;
  return t;
}

std::vector<RgbdFrame> load_frames(const std::string& name) {
  std::vector<RgbdFrame> frames;
  Result<std::unique_ptr<FrameSource>> source =
      open_frame_source(std::string(RGBDCAST_DATA_DIR) + "/" + name, SourceOptions{});
  if (!source) {
    std::fprintf(stderr, "%s: %s\n", name.c_str(), source.error().message.c_str());
    return frames;
  }
  for (size_t i = 0; i < (*source)->size(); ++i) {
    Result<RgbdFrame> f = (*source)->frame(i);
    if (!f) {
      std::fprintf(stderr, "%s: %s\n", name.c_str(), f.error().message.c_str());
      continue;
    }
    frames.push_back(std::move(*f));
  }
  return frames;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size() - 1) + 0.5))];
}

void tracking_table(int runs, const std::string& only) {
  struct Dataset {
    std::string name, ground_truth;
    PoseAssociation association;
  };
  const std::vector<Dataset> datasets = {
      {"tum/rgbd_dataset_freiburg1_xyz_200_319", "tum/rgbd_dataset_freiburg1_xyz_200_319/groundtruth.txt",
       PoseAssociation::kTimestamp},
      {"augmented_icl_livingroom", "augmented_icl_livingroom/trajectory.log", PoseAssociation::kIndex}};
  std::printf(
      "tracking, %d runs; ms per frame for tracking alone (features + match + RANSAC + ICP + keyframe "
      "decision, frames preloaded), wall and process CPU, median and p95 over the frames of the median "
      "run\n\n",
      runs);
  std::printf("%-40s %-5s %-8s %9s %6s %6s %11s %11s %11s %11s %8s %8s %8s %8s\n", "dataset", "feat", "method",
              "tracked", "wide", "reloc", "rmse m", "rmse deg", "worst m", "worst deg", "ms p50", "ms p95", "cpu p50",
              "cpu p95");
  for (const Dataset& d : datasets) {
    const std::vector<RgbdFrame> frames = load_frames(d.name);
    Result<Trajectory> gt = read_trajectory(std::string(RGBDCAST_DATA_DIR) + "/" + d.ground_truth);
    if (frames.size() < 2 || !gt) {
      std::fprintf(stderr, "%s: no frames or ground truth, skipped\n", d.name.c_str());
      continue;
    }
    for (FeatureType type : {FeatureType::kSift, FeatureType::kOrb})
      for (const char* method : {"paper", "robust", "live"}) {
        const bool paper = std::string(method) == "paper";
        if (!only.empty() && only != std::string(to_string(type)) + ":" + method) continue;
        SequenceParams params = std::string(method) == "live" ? SequenceParams::live() : SequenceParams{};
        params.odometry.features.type = type;
        if (paper) params.tracking = TrackingParams::paper_window_only();
        // Per frame: wall and process CPU time from the loader's return (a copy of cv::Mat headers) to the progress
        // callback, i.e. Tracker::push. CPU time counts OpenCV's worker threads too; on a loaded machine it is the
        // better estimate of the wall time on an idle one.
        struct Run {
          double total_ms = 0;
          std::vector<double> wall, cpu;
        };
        std::vector<Run> timed;
        Result<SequenceResult> r = make_error(ErrorCode::kEmpty, "not run");
        for (int run = 0; run < runs; ++run) {
          Run t;
          double wall0 = 0, cpu0 = 0;
          r = track_sequence(
              frames.size(),
              [&](size_t i) -> Result<RgbdFrame> {
                RgbdFrame f = frames[i];
                wall0 = now_ms();
                cpu0 = cpu_ms();
                return f;
              },
              params, {},
              [&](const FrameRecord&, size_t, size_t) {
                t.wall.push_back(now_ms() - wall0);
                t.cpu.push_back(cpu_ms() - cpu0);
                t.total_ms += t.wall.back();
              });
          if (!r) break;
          timed.push_back(std::move(t));
        }
        if (!r) {
          std::printf("%-40s %-5s %-8s failed: %s\n", d.name.c_str(), to_string(type), method,
                      r.error().message.c_str());
          continue;
        }
        std::sort(timed.begin(), timed.end(), [](const Run& a, const Run& b) { return a.total_ms < b.total_ms; });
        const Run& med = timed[timed.size() / 2];
        RpeParams rp;
        rp.association = d.association;
        Result<RpeResult> rpe = relative_pose_error(r->trajectory(), *gt, rp);
        char tracked[32];
        std::snprintf(tracked, sizeof tracked, "%zu/%zu", r->tracked, r->frames.size());
        if (!rpe) {
          std::printf("%-40s %-5s %-8s %9s no RPE: %s\n", d.name.c_str(), to_string(type), method, tracked,
                      rpe.error().message.c_str());
          continue;
        }
        std::printf("%-40s %-5s %-8s %9s %6zu %6zu %11.4f %11.3f %11.4f %11.3f %8.1f %8.1f %8.1f %8.1f\n",
                    d.name.c_str(), to_string(type), method, tracked, r->widened, r->relocalised,
                    rpe->translation_rmse_m, rpe->rotation_rmse_deg, rpe->translation_max_m, rpe->rotation_max_deg,
                    percentile(med.wall, 0.5), percentile(med.wall, 0.95), percentile(med.cpu, 0.5),
                    percentile(med.cpu, 0.95));
      }
  }
  std::printf("\n");
}

}  // namespace

int main(int argc, char** argv) {
  std::string mode = "all";
  int arg = 1;
  if (argc > 1 &&
      (std::string(argv[1]) == "stages" || std::string(argv[1]) == "tracking" || std::string(argv[1]) == "all"))
    mode = argv[arg++];
  const int runs = argc > arg ? std::max(1, std::atoi(argv[arg])) : 7;
  std::string load;
  std::getline(std::ifstream("/proc/loadavg"), load);
  if (mode != "stages") {
    std::printf("load average at start: %s (figures are only comparable on an idle machine)\n", load.c_str());
    tracking_table(runs, argc > arg + 1 ? argv[arg + 1] : "");
    if (mode == "tracking") return 0;
  }
  const std::vector<std::string> datasets = {"augmented_icl_livingroom", "tum/rgbd_dataset_freiburg1_xyz"};
  std::printf("keyframe stage, median of %d runs; ms are per frame; frames/s over the whole sequence\n", runs);
  std::printf("load average at start: %s (figures are only comparable on an idle machine)\n\n", load.c_str());
  std::printf("%-32s %-6s %-4s %7s %9s %9s %9s %9s %9s %8s %8s\n", "dataset", "feat", "icp", "frames", "frames/s",
              "detect", "match", "ransac", "icp", "matches", "inliers");
  for (const std::string& name : datasets) {
    const std::vector<RgbdFrame> frames = load_frames(name);
    if (frames.size() < 2) {
      std::fprintf(stderr, "%s: fewer than 2 frames, skipped\n", name.c_str());
      continue;
    }
    for (bool icp : {false, true})
      for (FeatureType type : {FeatureType::kSift, FeatureType::kOrb, FeatureType::kAkaze}) {
        run_once(frames, type, icp);  // warm-up
        std::vector<double> total, det, mat, ran, ic;
        RunTimes last;
        for (int r = 0; r < runs; ++r) {
          last = run_once(frames, type, icp);
          total.push_back(last.total_ms);
          det.push_back(last.detect_ms);
          mat.push_back(last.match_ms);
          ran.push_back(last.ransac_ms);
          ic.push_back(last.icp_ms);
        }
        const double n = static_cast<double>(frames.size()), pairs = n - 1;
        std::printf("%-32s %-6s %-4s %7zu %9.1f %9.1f %9.1f %9.2f %9.1f %8.0f %8.0f%s\n", name.c_str(), to_string(type),
                    icp ? "yes" : "no", frames.size(), 1000.0 * n / median(total), median(det) / n, median(mat) / pairs,
                    median(ran) / pairs, median(ic) / pairs, last.matches / pairs, last.inliers / pairs,
                    last.failed ? "  (some pairs failed)" : "");
      }
  }
  return 0;
}
