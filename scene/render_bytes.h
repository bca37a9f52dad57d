#pragma once
// What a renderer holds for a scene once it is uploaded (renderer/render_scene.h prepares it): 24-byte vertices (mesh
// vertices and points alike), 4-byte indices, and an RGBA8 texture per textured mesh (an encoded texture's size read
// from its header, without decoding it). The resident caps count in these bytes: the renderers' parts
// (service/render_pool.h) and the tiles' records, whose sums decide how coarse a view must be to fit
// (service/mission_view.h). Pure functions.
#include <cstddef>

#include "scene/scene.h"

namespace rgbdcast {

size_t render_bytes(const Mesh& mesh);
size_t render_bytes(const Scene& scene);

}  // namespace rgbdcast
