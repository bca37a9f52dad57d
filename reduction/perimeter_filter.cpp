#include "reduction/stages.h"

namespace rgbdcast {

std::vector<std::uint32_t> filter_by_perimeter(const Cloud& cloud, const std::vector<std::uint32_t>& triangles,
                                               double max_perimeter_m) {
  std::vector<std::uint32_t> kept;
  kept.reserve(triangles.size());
  for (size_t t = 0; t + 2 < triangles.size(); t += 3) {
    const Eigen::Vector3f a = cloud[triangles[t]].getVector3fMap(), b = cloud[triangles[t + 1]].getVector3fMap(),
                          c = cloud[triangles[t + 2]].getVector3fMap();
    const double perimeter = (b - a).norm() + (c - b).norm() + (a - c).norm();
    if (perimeter <= max_perimeter_m) kept.insert(kept.end(), {triangles[t], triangles[t + 1], triangles[t + 2]});
  }
  return kept;
}

}  // namespace rgbdcast
