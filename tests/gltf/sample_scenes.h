#pragma once
// Small scenes for glTF tests: a textured grid, a vertex-coloured mesh with its point cloud, a capture camera at a
// non-trivial pose, capture metadata in extras.
#include "scene/scene.h"

namespace rgbdcast::test {

// A textured grid (uvs in [0,1], an RGB gradient texture without encoded bytes) in front of the camera.
Mesh textured_grid(int n, float z_m);
Mesh coloured_grid(int n, float z_m);
Scene sample_scene();
// Texture with a smooth pattern so that JPEG round trips stay close.
Image gradient_texture(int w, int h);

}  // namespace rgbdcast::test
