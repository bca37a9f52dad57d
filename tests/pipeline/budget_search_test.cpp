// pipeline/budget_search.h: the quality search's steps against a JPEG model whose bytes follow a power of libjpeg's
// quantizer scale (the model the search interpolates in), and the search's bookkeeping on a shared real frame.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "pipeline/budget_search.h"
#include "tests/pipeline/realtime_frames.h"

namespace rgbdcast {
namespace {

// libjpeg's quantizer scale (jpeg_quality_scaling) for a quality in 1..100.
double quantizer_scale(double q) { return q < 50 ? 5000.0 / q : 200.0 - 2.0 * q; }

// JPEG bytes in the model: a power of the quantizer scale.
double model_bytes(double q, double exponent) { return 4.0e6 * std::pow(quantizer_scale(q), -exponent); }

std::vector<TriedJpeg> tried_at(const std::vector<int>& qualities, double scale, double exponent) {
  std::vector<TriedJpeg> tried;
  for (int q : qualities)
    tried.push_back({q, scale, std::vector<std::uint8_t>(static_cast<size_t>(model_bytes(q, exponent)))});
  return tried;
}

TEST(BudgetSearch, GuessFindsTheQualityOfTheModel) {
  struct Case {
    int q_lo, q_hi, q_true;
    double exponent;
  };
  const Case cases[] = {
      {20, 92, 55, 0.6}, {20, 92, 30, 0.6}, {20, 92, 85, 0.6}, {20, 98, 45, 0.9},
      {30, 60, 49, 0.7}, {30, 60, 51, 0.7}, {52, 54, 53, 0.5}, {20, 40, 21, 1.2},
  };
  for (const Case& c : cases) {
    // Just above the true quality's bytes: the floor of the interpolated quality is the true one.
    const double target = model_bytes(c.q_true, c.exponent) * (1 + 1e-9);
    const int q =
        guess_quality(c.q_lo, model_bytes(c.q_lo, c.exponent), c.q_hi, model_bytes(c.q_hi, c.exponent), target);
    EXPECT_EQ(q, c.q_true) << c.q_lo << ".." << c.q_hi << " exponent " << c.exponent;
  }
}

TEST(BudgetSearch, TriedBytesAreThoseOfTheQualityAndScale) {
  std::vector<TriedJpeg> tried = tried_at({20, 92}, 1.0, 0.6);
  const std::vector<TriedJpeg> half = tried_at({20}, 0.5, 0.6);
  tried.insert(tried.end(), half.begin(), half.end());
  tried[2].bytes.resize(100);
  struct Case {
    int q;
    double scale, bytes;
  };
  for (const Case& c :
       {Case{20, 1.0, std::floor(model_bytes(20, 0.6))}, Case{92, 1.0, std::floor(model_bytes(92, 0.6))},
        Case{20, 0.5, 100.0}, Case{92, 0.5, -1.0}, Case{50, 1.0, -1.0}})
    EXPECT_EQ(tried_bytes(tried, c.q, c.scale), c.bytes) << "q" << c.q << " at " << c.scale;
}

TEST(BudgetSearch, NarrowsToTheClosestQualitiesTriedAtTheScale) {
  const double e = 0.6;
  std::vector<TriedJpeg> tried = tried_at({20, 35, 50, 70, 92}, 1.0, e);
  const std::vector<TriedJpeg> other = tried_at({60, 65}, 0.5, e);  // another scale: ignored
  tried.insert(tried.end(), other.begin(), other.end());
  struct Case {
    double target;
    int lo, hi;
  };
  const Case cases[] = {
      {model_bytes(60, e), 50, 70},      // between two tried qualities
      {model_bytes(50, e) + 1, 50, 70},  // q50 fits
      {model_bytes(30, e), 20, 35},      // below the second
      {model_bytes(92, e) + 1, 70, 92},  // every quality inside fits
      {model_bytes(20, e) - 1, 20, 35},  // none inside fits
  };
  for (const Case& c : cases) {
    int lo = 20, hi = 92;
    narrow_to_tried(tried, 1.0, c.target, &lo, &hi);
    EXPECT_EQ(lo, c.lo) << c.target;
    EXPECT_EQ(hi, c.hi) << c.target;
  }
}

TEST(BudgetSearch, NextQualitiesStrictlyBetweenAroundTheGuess) {
  const double e = 0.6;
  struct Case {
    int lo, hi, q_true;
    std::vector<int> expected;
  };
  const Case cases[] = {
      {20, 92, 55, {53, 57}},  // two either side of the model's quality
      {20, 92, 21, {21, 23}},  // clamped above the lower end (21 - 2 -> 21)
      {50, 56, 55, {53, 55}},  // clamped below the upper end (57 -> 55)
      {40, 42, 41, {41}},      // one quality between: tried once
      {40, 41, 40, {}},        // nothing between
  };
  for (const Case& c : cases) {
    const std::vector<TriedJpeg> tried = tried_at({c.lo, c.hi}, 1.0, e);
    // Above the true quality's bytes by more than the tried sizes' rounding to whole bytes.
    const double target = model_bytes(c.q_true, e) * (1 + 1e-4);
    EXPECT_EQ(next_qualities(tried, 1.0, c.lo, c.hi, target), c.expected) << c.lo << ".." << c.hi;
  }
}

// The search's bookkeeping at several budgets on a real frame: the bytes it reports add up, the texture it keeps is
// the JPEG it reports, and "budget" is its last stage.
TEST(BudgetSearch, ReportsWhatItKeptOnARealFrame) {
  REQUIRE_DATA("tum/rgbd_dataset_freiburg1_xyz");
  auto frame = test::fr1_xyz_frame(0);
  ASSERT_TRUE(frame) << frame.error().message;
  const std::vector<std::string> rules = {"fits", "texture-fitted", "geometry-capped", "outline-capped", "over-budget"};
  for (double kb : {10.0, 25.0, 40.0, 120.0, 400.0}) {
    const FrameReductionOptions o = test::realtime(kb);
    auto t = reduce_and_texture(*frame, o);
    ASSERT_TRUE(t) << kb << " kB: " << t.error().message;
    const BudgetChoice& b = t->budget;
    const std::string at = std::to_string(kb) + " kB";
    EXPECT_EQ(b.budget_bytes, kb * 1000) << at;
    EXPECT_NE(std::find(rules.begin(), rules.end(), b.rule), rules.end()) << at << ": " << b.rule;
    EXPECT_EQ(b.texture_bytes, t->node.mesh.texture_encoded.size()) << at;
    EXPECT_EQ(t->node.mesh.texture_mime, "image/jpeg") << at;
    EXPECT_GE(b.glb_bytes, b.geometry_bytes + b.texture_bytes) << at;
    EXPECT_GE(b.jpeg_quality, kBudgetMinJpegQuality) << at;
    EXPECT_LE(b.jpeg_quality, o.budget_max_jpeg_quality) << at;
    EXPECT_GE(b.texture_scale, kBudgetMinTextureScale) << at;
    EXPECT_LE(b.texture_scale, 1.0) << at;
    EXPECT_GE(b.tolerance_factor, o.params.depth_mesh.tolerance_factor) << at;
    EXPECT_GE(b.meshes, 1) << at;
    EXPECT_GE(b.encodes, b.meshes + 1) << at;  // each mesh's geometry, and the texture at least once
    ASSERT_FALSE(t->stages.empty()) << at;
    EXPECT_EQ(t->stages.back().name, "budget") << at;
    EXPECT_EQ(t->stages.back().count, b.glb_bytes) << at;
    EXPECT_NE(t->geometry_cache, nullptr) << at;  // Draco: the final write reuses the measurement
  }
}

}  // namespace
}  // namespace rgbdcast
