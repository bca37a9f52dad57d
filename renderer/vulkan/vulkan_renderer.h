#pragma once
// The Vulkan backend: offscreen RGBA8 colour + D32 depth images, dynamic rendering (Vulkan 1.3), readback through
// host-visible buffers. Written for Mesa lavapipe; any Vulkan 1.3 device with large points works.
#include <memory>

#include "renderer/create_renderer.h"

namespace rgbdcast {

// kUnavailable (with what is missing) when no Vulkan 1.3 device can be used.
Result<std::unique_ptr<Renderer>> create_vulkan_renderer(const RendererConfig& config);

}  // namespace rgbdcast
