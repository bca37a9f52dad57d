#pragma once
// The one place that chooses a rendering backend (renderer/renderer.h is the interface it returns). In the library
// rgbdcast_renderer, with both backends; code that only draws through a Renderer links rgbdcast_renderer_api.
#include <memory>
#include <string>

#include "renderer/renderer.h"
#include "scene/result.h"

namespace rgbdcast {

struct RendererConfig {
  // Vulkan only: enable VK_LAYER_KHRONOS_validation and count its errors (tests). Creation fails when the layer is
  // not installed.
  bool vulkan_validation = false;
};

struct RendererSelection {
  std::unique_ptr<Renderer> renderer;
  std::string reason;  // why this backend: "requested", or what auto found ("no Vulkan device: ...")
};

// auto: Vulkan when a device is found, else OSMesa. When nothing works, one error says what is missing.
Result<RendererSelection> create_renderer(BackendChoice choice, const RendererConfig& config = {});

}  // namespace rgbdcast
