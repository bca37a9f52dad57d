#include <pcl/filters/statistical_outlier_removal.h>

#include "reduction/stages.h"

namespace rgbdcast {

std::vector<int> statistical_outliers_kdtree(const Cloud::ConstPtr& cloud, int k, double std_mul) {
  pcl::StatisticalOutlierRemoval<CloudPoint> sor;
  sor.setInputCloud(cloud);
  sor.setMeanK(k);
  sor.setStddevMulThresh(std_mul);
  pcl::Indices kept;
  sor.filter(kept);
  return std::vector<int>(kept.begin(), kept.end());
}

}  // namespace rgbdcast
