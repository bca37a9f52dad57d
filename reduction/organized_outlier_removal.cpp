#include <algorithm>
#include <cmath>
#include <vector>

#include "reduction/openmp_threads.h"
#include "reduction/stages.h"

namespace rgbdcast {

// The same statistic as PCL's StatisticalOutlierRemoval (mean distance to the k nearest neighbours; keep a point
// when that mean is at most mean + std_mul * stddev over the cloud), but the neighbours are searched among the valid
// pixels of a square window around the point's pixel instead of in a k-d tree over the whole cloud. On a depth image
// the 3D nearest neighbours of a surface point are its image neighbours; across a depth edge they are not, which
// only makes the flying pixels there look more like outliers, as they are. O(n * window^2) with no tree to build.
std::vector<int> statistical_outliers_organized(const Cloud& cloud, const std::vector<int>& pixel_of_point, int w,
                                                int h, int k, double std_mul, int threads) {
  // Window large enough to hold k valid neighbours on a fully valid image: (2r+1)^2 - 1 >= 1.6 k.
  int r = 1;
  while ((2 * r + 1) * (2 * r + 1) - 1 < static_cast<int>(1.6 * k)) ++r;

  std::vector<int> point_at(static_cast<size_t>(w) * h, -1);  // pixel -> point index
  for (size_t i = 0; i < pixel_of_point.size(); ++i) point_at[pixel_of_point[i]] = static_cast<int>(i);

  const int n = static_cast<int>(cloud.size());
  std::vector<float> mean_dist(n, INFINITY);
#pragma omp parallel num_threads(openmp_threads(threads))
  {
    std::vector<float> d;
    d.reserve((2 * r + 1) * (2 * r + 1));
#pragma omp for schedule(dynamic, 1024)
    for (int i = 0; i < n; ++i) {
      const int u = pixel_of_point[i] % w, v = pixel_of_point[i] / w;
      const Eigen::Vector3f p = cloud[i].getVector3fMap();
      d.clear();
      for (int y = std::max(0, v - r); y <= std::min(h - 1, v + r); ++y)
        for (int x = std::max(0, u - r); x <= std::min(w - 1, u + r); ++x) {
          const int j = point_at[static_cast<size_t>(y) * w + x];
          if (j >= 0 && j != i) d.push_back((cloud[j].getVector3fMap() - p).norm());
        }
      if (d.empty()) continue;  // isolated: an outlier by any measure (mean stays infinite)
      const size_t kk = std::min(d.size(), static_cast<size_t>(k));
      std::nth_element(d.begin(), d.begin() + (kk - 1), d.end());
      double sum = 0;
      for (size_t t = 0; t < kk; ++t) sum += d[t];
      mean_dist[i] = static_cast<float>(sum / kk);
    }
  }
  // Mean and standard deviation over the points that have neighbours, as PCL computes them.
  double sum = 0, sq = 0;
  size_t valid = 0;
  for (float m : mean_dist)
    if (std::isfinite(m)) sum += m, sq += double(m) * m, ++valid;
  std::vector<int> kept;
  if (valid == 0) return kept;
  const double mean = sum / valid;
  const double stddev = std::sqrt(std::max(0.0, (sq - sum * sum / valid) / std::max<size_t>(1, valid - 1)));
  const double threshold = mean + std_mul * stddev;
  kept.reserve(valid);
  for (int i = 0; i < n; ++i)
    if (mean_dist[i] <= threshold) kept.push_back(i);
  return kept;
}

}  // namespace rgbdcast
