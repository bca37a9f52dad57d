// Trajectory files (TUM, Redwood .log, ICL-NUIM pose.txt) and the relative pose error.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "keyframes/frame_odometry.h"
#include "keyframes/pose_error.h"
#include "keyframes/sequence_report.h"
#include "keyframes/trajectory_io.h"
#include "tests/common/test_data.h"

namespace rgbdcast {
namespace {

void expect_rotation(const Eigen::Matrix4d& t) {
  const Eigen::Matrix3d r = t.topLeftCorner<3, 3>();
  EXPECT_LT((r.transpose() * r - Eigen::Matrix3d::Identity()).norm(), 1e-6);
  EXPECT_NEAR(r.determinant(), 1.0, 1e-6);
}

std::string write_text(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string p = dir + "/" + name;
  std::ofstream(p) << text;
  return p;
}

TEST(TrajectoryIo, RedwoodLog) {
  REQUIRE_DATA("augmented_icl_livingroom/trajectory.log");
  Result<Trajectory> t = read_trajectory(test::data_path("augmented_icl_livingroom/trajectory.log"));
  ASSERT_TRUE(t) << t.error().message;
  ASSERT_EQ(t->poses.size(), 5u);
  EXPECT_TRUE(t->warnings.empty());
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(t->poses[static_cast<size_t>(i)].index, i);
    expect_rotation(t->poses[static_cast<size_t>(i)].camera_to_world);
  }
  EXPECT_NEAR(t->poses[0].camera_to_world(0, 3), -0.31057997014702826, 1e-15);
  EXPECT_NEAR(t->poses[4].camera_to_world(2, 3), 2.1203973483573484, 1e-15);
}

TEST(TrajectoryIo, IclPoseTxtNegativeFy) {
  REQUIRE_DATA("icl_nuim_livingroom/pose.txt");
  Result<Trajectory> conv = read_trajectory(test::data_path("icl_nuim_livingroom/pose.txt"));
  Result<Trajectory> raw = read_icl_pose_txt(test::data_path("icl_nuim_livingroom/pose.txt"), false);
  ASSERT_TRUE(conv && raw);
  ASSERT_EQ(conv->poses.size(), 5u);
  // First line: t = (0.000466347 0.00895357 -2.24935); converted, y flips sign.
  EXPECT_NEAR(raw->poses[0].camera_to_world(1, 3), 0.00895357, 1e-12);
  EXPECT_NEAR(conv->poses[0].camera_to_world(1, 3), -0.00895357, 1e-12);
  Eigen::Matrix4d s = Eigen::Matrix4d::Identity();
  s(1, 1) = -1;
  for (size_t i = 0; i < 5; ++i) {
    expect_rotation(conv->poses[i].camera_to_world);
    EXPECT_LT((conv->poses[i].camera_to_world - s * raw->poses[i].camera_to_world * s).norm(), 1e-12);
  }
  // A point seen by ICL's y-up camera at pixel (u, v) with fy = -480, and by rgbdcast's with fy = +480, lands on the
  // same (mirrored) world point: world_rgbdcast = S world_icl.
  const double u = 100, v = 50, z = 2.0;
  const Eigen::Vector4d p_icl((u - 319.5) / 481.2 * z, (v - 239.5) / -480.0 * z, z, 1);
  const Eigen::Vector4d p_cv((u - 319.5) / 481.2 * z, (v - 239.5) / 480.0 * z, z, 1);
  const Eigen::Vector4d w_icl = raw->poses[2].camera_to_world * p_icl;
  const Eigen::Vector4d w_cv = conv->poses[2].camera_to_world * p_cv;
  EXPECT_LT((s * w_icl - w_cv).norm(), 1e-12);
}

TEST(TrajectoryIo, TumGroundTruthAndNearest) {
  const std::string rel = "tum/rgbd_dataset_freiburg1_xyz/groundtruth_excerpt_1305031112.0-1305031113.5.txt";
  REQUIRE_DATA(rel);
  Result<Trajectory> t = read_trajectory(test::data_path(rel));
  ASSERT_TRUE(t) << t.error().message;
  // One pose per non-comment line (151: 100 Hz from .0057 to 1.5057 s; the data README says 150).
  size_t lines = 0;
  std::ifstream in(test::data_path(rel));
  for (std::string l; std::getline(in, l);) lines += (!l.empty() && l[0] != '#') ? 1 : 0;
  EXPECT_EQ(t->poses.size(), lines);
  EXPECT_GE(t->poses.size(), 150u);
  EXPECT_TRUE(t->warnings.empty());
  const StampedPose* p = nearest_pose(*t, 1305031112.012, 0.02);
  ASSERT_NE(p, nullptr);
  EXPECT_DOUBLE_EQ(p->timestamp, 1305031112.0157);
  EXPECT_NEAR(p->camera_to_world(1, 3), 0.7152, 1e-12);
  expect_rotation(p->camera_to_world);
  // The fr1/xyz frames on disk (t = 1305031102.x) have no ground truth in the excerpt.
  EXPECT_EQ(nearest_pose(*t, 1305031102.175304, 0.02), nullptr);
}

TEST(TrajectoryIo, BadFilesGiveClearMessages) {
  Result<Trajectory> missing = read_tum_trajectory("/nonexistent/groundtruth.txt");
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().code, ErrorCode::kNotFound);
  EXPECT_EQ(missing.error().message, "ground-truth file not found: /nonexistent/groundtruth.txt");
  EXPECT_EQ(read_redwood_log("/nonexistent/t.log").error().code, ErrorCode::kNotFound);
  EXPECT_EQ(read_trajectory("/nonexistent/pose.txt").error().code, ErrorCode::kNotFound);

  const std::string dir = test::temp_dir("traj");
  // Out of order, a duplicate and a garbage line: sorted, deduplicated, warned about.
  Result<Trajectory> t = read_tum_trajectory(write_text(dir, "gt.txt",
                                                        "# comment\n"
                                                        "3.0 0 0 3 0 0 0 1\n"
                                                        "1.0 0 0 1 0 0 0 1\n"
                                                        "2.0 0 0 2 0 0 0 1\n"
                                                        "2.0 0 0 2 0 0 0 1\n"
                                                        "2.5 zero 0 2 0 0 0 1\n"));
  ASSERT_TRUE(t) << t.error().message;
  ASSERT_EQ(t->poses.size(), 3u);
  EXPECT_DOUBLE_EQ(t->poses[0].timestamp, 1.0);
  EXPECT_DOUBLE_EQ(t->poses[2].camera_to_world(2, 3), 3.0);
  ASSERT_EQ(t->warnings.size(), 3u);
  EXPECT_NE(t->warnings[0].find("gt.txt:6"), std::string::npos) << t->warnings[0];
  EXPECT_NE(t->warnings[1].find("out of order"), std::string::npos);
  EXPECT_NE(t->warnings[2].find("duplicate"), std::string::npos);

  Result<Trajectory> trunc = read_redwood_log(write_text(dir, "t.log", "0 0 1\n1 0 0 0\n0 1 0 0\n"));
  ASSERT_FALSE(trunc);
  EXPECT_EQ(trunc.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(trunc.error().message.find("truncated"), std::string::npos) << trunc.error().message;
  EXPECT_EQ(read_trajectory(write_text(dir, "x.txt", "1 2 3\n")).error().code, ErrorCode::kInvalidInput);
  EXPECT_EQ(read_tum_trajectory(write_text(dir, "empty.txt", "# nothing\n")).error().code, ErrorCode::kInvalidInput);
  std::filesystem::remove_all(dir);
}

TEST(TrajectoryIo, WriteReadRoundTrip) {
  Trajectory t;
  for (int i = 0; i < 4; ++i) {
    StampedPose p;
    p.index = i;
    p.timestamp = 100.0 + 0.033 * i;
    p.camera_to_world.topLeftCorner<3, 3>() =
        Eigen::AngleAxisd(0.1 * i, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    p.camera_to_world.topRightCorner<3, 1>() = Eigen::Vector3d(0.1 * i, -0.2 * i, 0.05);
    t.poses.push_back(p);
  }
  const std::string dir = test::temp_dir("traj-rt");
  ASSERT_TRUE(write_tum_trajectory(dir + "/est.txt", t));
  ASSERT_TRUE(write_redwood_log(dir + "/est.log", t));
  Result<Trajectory> a = read_trajectory(dir + "/est.txt");
  Result<Trajectory> b = read_trajectory(dir + "/est.log");
  ASSERT_TRUE(a && b);
  ASSERT_EQ(a->poses.size(), 4u);
  ASSERT_EQ(b->poses.size(), 4u);
  for (size_t i = 0; i < 4; ++i) {
    EXPECT_NEAR(a->poses[i].timestamp, t.poses[i].timestamp, 1e-6);
    EXPECT_LT((a->poses[i].camera_to_world - t.poses[i].camera_to_world).norm(), 1e-6);
    EXPECT_LT((b->poses[i].camera_to_world - t.poses[i].camera_to_world).norm(), 1e-12);
  }
  // The two trajectories and no temporary file.
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), std::filesystem::directory_iterator()), 2);
  std::filesystem::remove_all(dir);
}

TEST(PoseError, KnownPerturbation) {
  Trajectory gt, est;
  Eigen::Matrix4d world_shift = Eigen::Matrix4d::Identity();  // the estimate lives in another world frame
  world_shift.topLeftCorner<3, 3>() = Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  world_shift(0, 3) = 5.0;
  for (int i = 0; i < 5; ++i) {
    StampedPose g;
    g.index = i;
    g.timestamp = i * 0.1;
    g.camera_to_world(0, 3) = 0.02 * i;
    gt.poses.push_back(g);
    StampedPose e = g;
    e.camera_to_world = world_shift * g.camera_to_world;
    if (i == 3) e.camera_to_world(1, 3) += 0.004;  // 4 mm off at frame 3
    est.poses.push_back(e);
  }
  Result<RpeResult> r = relative_pose_error(est, gt);
  ASSERT_TRUE(r) << r.error().message;
  ASSERT_EQ(r->pairs.size(), 4u);
  EXPECT_NEAR(r->pairs[0].translation_m, 0.0, 1e-12);
  EXPECT_NEAR(r->pairs[2].translation_m, 0.004, 1e-9);  // 2 -> 3
  EXPECT_NEAR(r->pairs[3].translation_m, 0.004, 1e-9);  // 3 -> 4
  EXPECT_NEAR(r->translation_max_m, 0.004, 1e-9);
  EXPECT_NEAR(r->pairs[1].gt_translation_m, 0.02, 1e-12);
  EXPECT_NEAR(r->rotation_max_deg, 0.0, 1e-6);

  // Estimated poses without ground truth are skipped with a warning; none at all is an error.
  est.poses[1].timestamp = 7.0;
  est.poses[2].timestamp = 7.1;
  Result<RpeResult> partial = relative_pose_error(est, gt);
  ASSERT_TRUE(partial);
  EXPECT_EQ(partial->pairs.size(), 2u);  // 0 -> 3, 3 -> 4
  EXPECT_FALSE(partial->warnings.empty());
  Trajectory far = est;
  for (auto& p : far.poses) p.timestamp += 100.0;
  Result<RpeResult> none = relative_pose_error(far, gt);
  ASSERT_FALSE(none);
  EXPECT_EQ(none.error().code, ErrorCode::kEmpty);
  const nlohmann::json j = rpe_json(*r);
  EXPECT_EQ(j["pairs"].size(), 4u);
}

}  // namespace
}  // namespace rgbdcast
