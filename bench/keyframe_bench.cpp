// Frames per second of the keyframe stage (detect + windowed FLANN match + RANSAC, and the optional ICP refinement
// on top) with SIFT, ORB and AKAZE on the real captures. Frames are loaded once; each run processes the sequence in
// order (frame 0: detect only). Prints the median of several runs.
//   keyframe_bench [runs=7]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "keyframes/frame_odometry.h"
#include "input/frame_source.h"

using namespace rgbdcast;

namespace {

double now_ms() {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count();
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

}  // namespace

int main(int argc, char** argv) {
  const int runs = argc > 1 ? std::max(1, std::atoi(argv[1])) : 7;
  const std::vector<std::string> datasets = {"augmented_icl_livingroom", "tum/rgbd_dataset_freiburg1_xyz"};
  std::string load;
  std::getline(std::ifstream("/proc/loadavg"), load);
  std::printf("keyframe stage, median of %d runs; ms are per frame; frames/s over the whole sequence\n", runs);
  std::printf("load average at start: %s (figures are only comparable on an idle machine)\n\n", load.c_str());
  std::printf("%-32s %-6s %-4s %7s %9s %9s %9s %9s %9s %8s %8s\n", "dataset", "feat", "icp", "frames", "frames/s",
              "detect", "match", "ransac", "icp", "matches", "inliers");
  for (const std::string& name : datasets) {
    std::vector<RgbdFrame> frames;
    Result<std::unique_ptr<FrameSource>> source =
        open_frame_source(std::string(RGBDCAST_DATA_DIR) + "/" + name, SourceOptions{});
    if (!source) {
      std::fprintf(stderr, "%s: %s\n", name.c_str(), source.error().message.c_str());
      continue;
    }
    for (size_t i = 0; i < (*source)->size(); ++i) {
      Result<RgbdFrame> f = (*source)->frame(i);
      if (!f) {
        std::fprintf(stderr, "%s: %s\n", name.c_str(), f.error().message.c_str());
        continue;
      }
      frames.push_back(std::move(*f));
    }
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
        std::printf("%-32s %-6s %-4s %7zu %9.1f %9.1f %9.1f %9.2f %9.1f %8.0f %8.0f%s\n", name.c_str(),
                    to_string(type), icp ? "yes" : "no", frames.size(), 1000.0 * n / median(total), median(det) / n,
                    median(mat) / pairs, median(ran) / pairs, median(ic) / pairs, last.matches / pairs,
                    last.inliers / pairs, last.failed ? "  (some pairs failed)" : "");
      }
  }
  return 0;
}
