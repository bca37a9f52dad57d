#pragma once
// The point type that flows between the PCL stages of the reduction (internal to reduction/).
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

namespace rgbdcast {

using CloudPoint = pcl::PointXYZRGB;
using Cloud = pcl::PointCloud<CloudPoint>;

}  // namespace rgbdcast
