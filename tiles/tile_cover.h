#pragma once
// Newer keyframes supersede the older surface they cover. A place seen on every pass of a long mission would
// otherwise hold one layer per pass: every leaf drawn by a view that refines there, and every layer merged into the
// inner tiles above it. A keyframe's surface is what its camera saw last: where a newer keyframe saw the same surface
// (each of a triangle's three corners lands on the newer keyframe's own depth, within the sensor's noise, and the
// newer camera was not much farther from it), the older triangle is dropped from its leaf. "Newer" is the higher seq.
//
// The newer keyframe's depth is its own reduced surface rasterised at its capture camera, at half the capture
// resolution, its nearest and farthest layer; a corner is on it when a pixel within one of where it projects holds
// its range in either (so that a corner on the outline of an identical surface counts as seen). A triangle's coverage
// by one keyframe does not depend on any other keyframe, so what a set of newer keyframes covers is the union of what
// each covers, whatever the order they came in.
#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Geometry>

#include "scene/scene.h"

namespace rgbdcast::tiles {

struct CoverOptions {
  double depth_tolerance_m = 0.03;  // plus 3 sigma of Kinect depth noise at the newer camera's range
  // A newer view at most this much farther from a corner than the older one's camera: farther, it sampled the
  // surface too coarsely to stand in for the older, closer view.
  double max_range_ratio = 1.5;
  int downscale = 2;  // the depth is rasterised at the capture resolution divided by this
};

// A keyframe's own depth as its capture camera (cameras[0]) saw its placed surface.
struct CoverDepth {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  int width = 0, height = 0;
  Eigen::Matrix4d world_to_camera = Eigen::Matrix4d::Identity();
  // Row-major, the nearest surface and the farthest (where the reduced surface folds over itself, the older copy
  // of a layer it hides is covered too); 0 = no surface.
  std::vector<float> depth_m, far_m;
  Eigen::AlignedBox3d box;  // the surface's world box, grown by what coverage tolerates
};

// nullopt when the scene has no capture camera or no triangle in front of it.
std::optional<CoverDepth> cover_depth(const Scene& placed, const CoverOptions& options);

// The world box of a placed keyframe's surface, grown by the depth tolerance at its farthest corner: a triangle of
// another keyframe that this one covers lies inside it.
Eigen::AlignedBox3d cover_box(const Scene& placed, const CoverOptions& options);

// Marks in `covered` (one flag per triangle of the placed scene's meshed nodes, in node then index order; resized
// when empty) the triangles that `newer` covers. Returns how many of them it newly marked.
size_t mark_covered(const Scene& placed, const CoverDepth& newer, const CoverOptions& options,
                    std::vector<bool>& covered);

// The placed scene without the triangles `covered` marks (vertices no kept triangle uses dropped; textures kept as
// they are). Triangle order is that of mark_covered.
Scene without_covered(const Scene& placed, const std::vector<bool>& covered);

}  // namespace rgbdcast::tiles
