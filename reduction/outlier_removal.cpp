#include <pcl/filters/statistical_outlier_removal.h>

#include "reduction/stages.h"

namespace rgbdcast {

Cloud::Ptr remove_statistical_outliers(const Cloud::ConstPtr& cloud, int k, double std_mul) {
  auto out = std::make_shared<Cloud>();
  pcl::StatisticalOutlierRemoval<CloudPoint> sor;
  sor.setInputCloud(cloud);
  sor.setMeanK(k);
  sor.setStddevMulThresh(std_mul);
  sor.filter(*out);
  return out;
}

}  // namespace rgbdcast
