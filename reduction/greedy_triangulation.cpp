#include <pcl/common/io.h>
#include <pcl/features/normal_3d_omp.h>
#include <pcl/search/kdtree.h>
#include <pcl/surface/gp3.h>

#include "reduction/openmp_threads.h"
#include "reduction/stages.h"

namespace rgbdcast {

std::vector<std::uint32_t> greedy_triangulate(const Cloud::ConstPtr& cloud, const ReductionParams& params) {
  std::vector<std::uint32_t> indices;
  if (cloud->size() < 3) return indices;

  auto tree = std::make_shared<pcl::search::KdTree<CloudPoint>>();
  tree->setInputCloud(cloud);
  pcl::PointCloud<pcl::Normal> normals;
  pcl::NormalEstimationOMP<CloudPoint, pcl::Normal> ne;
  ne.setInputCloud(cloud);
  ne.setSearchMethod(tree);
  ne.setKSearch(params.normal_k);
  ne.setViewPoint(0.f, 0.f, 0.f);                         // the camera: normals face it
  ne.setNumberOfThreads(openmp_threads(params.threads));  // else PCL takes every core, whatever OMP_NUM_THREADS says
  ne.compute(normals);

  auto with_normals = std::make_shared<pcl::PointCloud<pcl::PointXYZRGBNormal>>();
  pcl::concatenateFields(*cloud, normals, *with_normals);
  auto tree2 = std::make_shared<pcl::search::KdTree<pcl::PointXYZRGBNormal>>();
  tree2->setInputCloud(with_normals);

  pcl::GreedyProjectionTriangulation<pcl::PointXYZRGBNormal> gp3;
  gp3.setSearchRadius(params.max_edge_m);
  gp3.setMu(params.mu);
  gp3.setMaximumNearestNeighbors(params.max_neighbours);
  gp3.setMaximumSurfaceAngle(M_PI / 4);  // 45 degrees
  gp3.setMinimumAngle(M_PI / 18);        // 10 degrees
  gp3.setMaximumAngle(2 * M_PI / 3);     // 120 degrees
  gp3.setNormalConsistency(false);
  gp3.setInputCloud(with_normals);
  gp3.setSearchMethod(tree2);
  std::vector<pcl::Vertices> polygons;
  gp3.reconstruct(polygons);

  indices.reserve(polygons.size() * 3);
  for (const auto& poly : polygons) {
    if (poly.vertices.size() != 3) continue;
    std::uint32_t a = poly.vertices[0], b = poly.vertices[1], c = poly.vertices[2];
    const Eigen::Vector3f pa = (*cloud)[a].getVector3fMap(), pb = (*cloud)[b].getVector3fMap(),
                          pc = (*cloud)[c].getVector3fMap();
    // Counter-clockwise seen from the camera at the origin: the right-hand normal points back at the camera.
    if ((pb - pa).cross(pc - pa).dot(pa) > 0.f) std::swap(b, c);
    indices.insert(indices.end(), {a, b, c});
  }
  return indices;
}

}  // namespace rgbdcast
