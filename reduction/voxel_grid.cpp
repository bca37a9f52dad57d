#include <pcl/filters/voxel_grid.h>

#include "reduction/stages.h"

namespace rgbdcast {

Cloud::Ptr voxel_downsample(const Cloud::ConstPtr& cloud, double voxel_size_m) {
  auto out = std::make_shared<Cloud>();
  pcl::VoxelGrid<CloudPoint> grid;
  grid.setInputCloud(cloud);
  const float s = static_cast<float>(voxel_size_m);
  grid.setLeafSize(s, s, s);
  grid.filter(*out);
  return out;
}

}  // namespace rgbdcast
