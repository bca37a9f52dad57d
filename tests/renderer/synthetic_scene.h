#pragma once
// A small synthetic scene built in code for the renderer's golden tests: a textured quad (a 16x12 grid, so points
// mode has texture-coloured vertices), three vertex-coloured triangles under a rotated, translated node, and a
// coloured point cloud. Plus the two fixed cameras of the goldens.
#include "renderer/renderer.h"
#include "scene/scene.h"

namespace rgbdcast::test {

Scene synthetic_scene();
// 320x240 intrinsics camera (fx = fy = 300) at the world origin.
ViewCamera intrinsics_camera();
// 320x240 look-at camera from the upper left, 60 degree vertical field of view.
ViewCamera look_at_camera();

}  // namespace rgbdcast::test
