// The one place that chooses a backend. auto: Vulkan when a usable device is found, else OSMesa; the reason says
// which and why. When neither works, one error names what each backend is missing.
#include "renderer/create_renderer.h"
#include "renderer/osmesa/osmesa_renderer.h"
#include "renderer/vulkan/vulkan_renderer.h"

namespace rgbdcast {

Result<RendererSelection> create_renderer(BackendChoice choice, const RendererConfig& config) {
  if (choice == BackendChoice::kVulkan) {
    auto r = create_vulkan_renderer(config);
    if (!r) return r.error();
    return RendererSelection{std::move(r.value()), "requested"};
  }
  if (choice == BackendChoice::kOsmesa) {
    auto r = create_osmesa_renderer();
    if (!r) return r.error();
    return RendererSelection{std::move(r.value()), "requested"};
  }
  auto vk = create_vulkan_renderer(config);
  if (vk) {
    std::string device = vk.value()->device();
    return RendererSelection{std::move(vk.value()), "auto: Vulkan device found (" + device + ")"};
  }
  auto gl = create_osmesa_renderer();
  if (gl) return RendererSelection{std::move(gl.value()), "auto: no usable Vulkan device (" + vk.error().message + ")"};
  return make_error(ErrorCode::kUnavailable, "no renderer available: " + vk.error().message + "; " +
                                                 gl.error().message + " (install mesa-vulkan-drivers or libosmesa6)");
}

}  // namespace rgbdcast
