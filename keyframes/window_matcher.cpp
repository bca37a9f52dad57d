#include "keyframes/window_matcher.h"

#include <cmath>
#include <opencv2/features2d.hpp>
#include <opencv2/flann.hpp>
#include <unordered_map>

namespace rgbdcast {

Status MatchParams::validate() const {
  if (window_px < 0 || window_px > 10000) return make_error(ErrorCode::kInvalidArgument, "window must be in [0, 10000] px");
  if (knn < 1 || knn > 100) return make_error(ErrorCode::kInvalidArgument, "knn must be in [1, 100]");
  if (!(ratio > 0 && ratio <= 1)) return make_error(ErrorCode::kInvalidArgument, "ratio must be in (0, 1]");
  return ok_status();
}

bool inside_window(const cv::Point2f& a, const cv::Point2f& b, int window_px) {
  if (window_px <= 0) return true;
  const float half = 0.5f * static_cast<float>(window_px);
  return std::abs(a.x - b.x) <= half && std::abs(a.y - b.y) <= half;
}

std::vector<FeatureMatch> match_in_window(const FrameFeatures& prev, const FrameFeatures& cur, const MatchParams& params) {
  std::vector<FeatureMatch> out;
  if (prev.descriptors.empty() || cur.descriptors.empty()) return out;
  if (prev.descriptors.type() != cur.descriptors.type() || prev.descriptors.cols != cur.descriptors.cols) return out;

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
      if (!first) first = &m;
      else if (!second) { second = &m; break; }
    }
    if (!first) continue;
    if (second && params.ratio < 1.0 && first->distance > params.ratio * second->distance) continue;
    FeatureMatch fm{first->trainIdx, static_cast<int>(q), first->distance};
    if (params.one_to_one) {
      auto it = best_for_prev.find(fm.prev);
      if (it != best_for_prev.end()) {
        if (out[it->second].distance > fm.distance) out[it->second] = fm;
        continue;
      }
      best_for_prev.emplace(fm.prev, out.size());
    }
    out.push_back(fm);
  }
  return out;
}

}  // namespace rgbdcast
