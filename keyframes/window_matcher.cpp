#include "keyframes/window_matcher.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core/hal/hal.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/flann.hpp>
#include <unordered_map>

namespace rgbdcast {

Status MatchParams::validate() const {
  if (window_px < 0 || window_px > 10000)
    return make_error(ErrorCode::kInvalidArgument, "window must be in [0, 10000] px");
  if (knn < 1 || knn > 100) return make_error(ErrorCode::kInvalidArgument, "knn must be in [1, 100]");
  if (!(ratio > 0 && ratio <= 1)) return make_error(ErrorCode::kInvalidArgument, "ratio must be in (0, 1]");
  return ok_status();
}

bool inside_window(const cv::Point2f& a, const cv::Point2f& b, int window_px) {
  if (window_px <= 0) return true;
  const float half = 0.5f * static_cast<float>(window_px);
  return std::abs(a.x - b.x) <= half && std::abs(a.y - b.y) <= half;
}

namespace {

// Keeps a candidate unless the ratio test or the one-to-one rule drops it.
void keep_match(const FeatureMatch& fm, bool have_second, float second, const MatchParams& params,
                std::unordered_map<int, size_t>& best_for_prev, std::vector<FeatureMatch>& out) {
  if (have_second && params.ratio < 1.0 && fm.distance > params.ratio * second) return;
  if (params.one_to_one) {
    auto it = best_for_prev.find(fm.prev);
    if (it != best_for_prev.end()) {
      if (out[it->second].distance > fm.distance) out[it->second] = fm;
      return;
    }
    best_for_prev.emplace(fm.prev, out.size());
  }
  out.push_back(fm);
}

// Exact search inside the window: previous keypoints sorted by x, each current keypoint compared with those in
// its x band that also fall inside the window in y.
std::vector<FeatureMatch> match_exact(const FrameFeatures& prev, const FrameFeatures& cur, const MatchParams& params) {
  std::vector<FeatureMatch> out;
  std::unordered_map<int, size_t> best_for_prev;
  const bool binary = prev.descriptors.type() != CV_32F;
  const int n = prev.descriptors.cols;
  auto distance = [&](int p, int c) -> float {
    if (binary)
      return static_cast<float>(cv::hal::normHamming(prev.descriptors.ptr<uchar>(p), cur.descriptors.ptr<uchar>(c), n));
    return std::sqrt(cv::hal::normL2Sqr_(prev.descriptors.ptr<float>(p), cur.descriptors.ptr<float>(c), n));
  };
  if (params.window_px <= 0) {
    cv::BFMatcher matcher(binary ? cv::NORM_HAMMING : cv::NORM_L2);
    std::vector<std::vector<cv::DMatch>> knn;
    matcher.knnMatch(cur.descriptors, prev.descriptors, knn, std::min(2, prev.descriptors.rows));
    for (size_t q = 0; q < knn.size(); ++q) {
      if (knn[q].empty()) continue;
      keep_match({knn[q][0].trainIdx, static_cast<int>(q), knn[q][0].distance}, knn[q].size() > 1,
                 knn[q].size() > 1 ? knn[q][1].distance : 0.f, params, best_for_prev, out);
    }
    return out;
  }
  std::vector<int> order(prev.keypoints.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return prev.keypoints[a].pt.x < prev.keypoints[b].pt.x; });
  std::vector<float> xs(order.size());
  for (size_t i = 0; i < order.size(); ++i) xs[i] = prev.keypoints[order[i]].pt.x;
  const float half = 0.5f * static_cast<float>(params.window_px);
  for (size_t q = 0; q < cur.keypoints.size(); ++q) {
    const cv::Point2f at = cur.keypoints[q].pt;
    int best = -1;
    float d1 = std::numeric_limits<float>::max(), d2 = d1;
    for (auto it = std::lower_bound(xs.begin(), xs.end(), at.x - half); it != xs.end() && *it <= at.x + half; ++it) {
      const int p = order[static_cast<size_t>(it - xs.begin())];
      if (std::abs(prev.keypoints[p].pt.y - at.y) > half) continue;
      const float d = distance(p, static_cast<int>(q));
      if (d < d1) {
        d2 = d1;
        d1 = d;
        best = p;
      } else if (d < d2) {
        d2 = d;
      }
    }
    if (best < 0) continue;
    keep_match({best, static_cast<int>(q), d1}, d2 < std::numeric_limits<float>::max(), d2, params, best_for_prev, out);
  }
  return out;
}

}  // namespace

std::vector<FeatureMatch> match_in_window(const FrameFeatures& prev, const FrameFeatures& cur,
                                          const MatchParams& params) {
  std::vector<FeatureMatch> out;
  if (prev.descriptors.empty() || cur.descriptors.empty()) return out;
  if (prev.descriptors.type() != cur.descriptors.type() || prev.descriptors.cols != cur.descriptors.cols) return out;
  if (params.exact_window) return match_exact(prev, cur, params);

  // KD-tree for float descriptors, LSH for binary ones (FLANN's own choices for these metrics).
  cv::Ptr<cv::DescriptorMatcher> matcher;
  if (prev.descriptors.type() == CV_32F)
    matcher = cv::makePtr<cv::FlannBasedMatcher>(cv::makePtr<cv::flann::KDTreeIndexParams>(4),
                                                 cv::makePtr<cv::flann::SearchParams>(64));
  else
    matcher = cv::makePtr<cv::FlannBasedMatcher>(cv::makePtr<cv::flann::LshIndexParams>(6, 12, 1),
                                                 cv::makePtr<cv::flann::SearchParams>(64));
  const int k = std::min(params.knn, prev.descriptors.rows);
  std::vector<std::vector<cv::DMatch>> knn;
  matcher->knnMatch(cur.descriptors, prev.descriptors, knn, k);

  std::unordered_map<int, size_t> best_for_prev;  // previous keypoint -> position in out
  for (size_t q = 0; q < knn.size(); ++q) {
    const cv::Point2f at = cur.keypoints[q].pt;
    const cv::DMatch* first = nullptr;
    const cv::DMatch* second = nullptr;
    for (const cv::DMatch& m : knn[q]) {  // sorted by descriptor distance
      if (m.trainIdx < 0 || m.trainIdx >= static_cast<int>(prev.keypoints.size())) continue;
      if (!inside_window(at, prev.keypoints[m.trainIdx].pt, params.window_px)) continue;
      if (!first)
        first = &m;
      else if (!second) {
        second = &m;
        break;
      }
    }
    if (!first) continue;
    keep_match({first->trainIdx, static_cast<int>(q), first->distance}, second != nullptr,
               second ? second->distance : 0.f, params, best_for_prev, out);
  }
  return out;
}

}  // namespace rgbdcast
