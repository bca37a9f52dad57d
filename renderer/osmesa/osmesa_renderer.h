#pragma once
// The OSMesa backend: OpenGL 4.5 core on llvmpipe through OSMesaCreateContextAttribs, drawing into its own
// framebuffer object (RGBA8 + 32-bit float depth). libOSMesa exports the GL entry points; never link libGL as well.
#include <memory>

#include "renderer/renderer.h"

namespace rgbdcast {

// kUnavailable (with what is missing) when no OpenGL 4.5 core context can be created.
Result<std::unique_ptr<Renderer>> create_osmesa_renderer();

}  // namespace rgbdcast
