// The keyframe stage on the real captures of ../shared/data.
#include <gtest/gtest.h>

#include <cstdio>

#include "keyframes/pose_error.h"
#include "keyframes/sequence.h"
#include "keyframes/trajectory_io.h"
#include "tests/common/test_data.h"
#include "tests/keyframes/test_frames.h"

namespace rgbdcast {
namespace {

void print_rpe(const std::string& label, const RpeResult& rpe) {
  for (const RpePair& p : rpe.pairs)
    std::printf("[%s] %d->%d: RPE %.4f m %.3f deg (true motion %.4f m %.3f deg)\n", label.c_str(), p.from_index,
                p.to_index, p.translation_m, p.rotation_deg, p.gt_translation_m, p.gt_rotation_deg);
  std::printf("[%s] RMSE %.4f m %.3f deg, max %.4f m %.3f deg\n", label.c_str(), rpe.translation_rmse_m,
              rpe.rotation_rmse_deg, rpe.translation_max_m, rpe.rotation_max_deg);
}

void print_frames(const std::string& label, const SequenceResult& r) {
  for (const FrameRecord& f : r.frames)
    std::printf("[%s] frame %zu: tracked %d matches %d inliers %d keyframe %d icp %d %.1f ms %s\n", label.c_str(),
                f.index, f.tracked, f.matches, f.inliers, f.keyframe, f.icp_used, f.ms, f.message.c_str());
}

Result<RpeResult> run_augmented_icl(FeatureType type, bool icp, const std::string& label) {
  const test::TestSequence seq = test::augmented_icl_sequence();
  SequenceParams params;
  params.odometry.features.type = type;
  params.odometry.refine_icp = icp;
  Result<SequenceResult> r = track_sequence(seq.frames.size(), seq.loader(), params);
  if (!r) return r.error();
  print_frames(label, *r);
  Result<Trajectory> gt = read_redwood_log(test::data_path("augmented_icl_livingroom/trajectory.log"));
  if (!gt) return gt.error();
  RpeParams rp;
  rp.association = PoseAssociation::kIndex;
  Result<RpeResult> rpe = relative_pose_error(r->trajectory(), *gt, rp);
  if (rpe) print_rpe(label, *rpe);
  return rpe;
}

TEST(KeyframesDatasets, AugmentedIclSiftWithIcp) {
  REQUIRE_DATA("augmented_icl_livingroom/trajectory.log");
  Result<RpeResult> rpe = run_augmented_icl(FeatureType::kSift, true, "aug-icl sift+icp");
  ASSERT_TRUE(rpe) << rpe.error().message;
  EXPECT_EQ(rpe->pairs.size(), 4u);
  for (const RpePair& p : rpe->pairs) {
    EXPECT_LT(p.translation_m, 0.01) << p.from_index << "->" << p.to_index;
    EXPECT_LT(p.rotation_deg, 0.5) << p.from_index << "->" << p.to_index;
  }
}

TEST(KeyframesDatasets, AugmentedIclFeaturesOnly) {
  REQUIRE_DATA("augmented_icl_livingroom/trajectory.log");
  for (FeatureType t : {FeatureType::kSift, FeatureType::kOrb, FeatureType::kAkaze}) {
    Result<RpeResult> rpe = run_augmented_icl(t, false, std::string("aug-icl ") + to_string(t) + " only");
    ASSERT_TRUE(rpe) << rpe.error().message;
    EXPECT_EQ(rpe->pairs.size(), 4u);
  }
}

}  // namespace
}  // namespace rgbdcast
