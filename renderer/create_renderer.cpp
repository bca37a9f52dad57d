// The one place that chooses a backend. auto: Vulkan when a usable device is found, else OSMesa; the reason says
// which and why. When neither works, one error names what each backend is missing.
#include "renderer/osmesa/osmesa_renderer.h"
#include "renderer/renderer.h"
#include "renderer/vulkan/vulkan_renderer.h"

namespace rgbdcast {

const char* to_string(RenderMode mode) { return mode == RenderMode::kMesh ? "mesh" : "points"; }

const char* to_string(BackendChoice choice) {
  switch (choice) {
    case BackendChoice::kAuto: return "auto";
    case BackendChoice::kVulkan: return "vulkan";
    case BackendChoice::kOsmesa: return "osmesa";
  }
  return "auto";
}

Result<BackendChoice> parse_backend_choice(const std::string& name) {
  if (name == "auto") return BackendChoice::kAuto;
  if (name == "vulkan") return BackendChoice::kVulkan;
  if (name == "osmesa") return BackendChoice::kOsmesa;
  return make_error(ErrorCode::kInvalidArgument, "unknown backend '" + name + "' (auto, vulkan or osmesa)");
}

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
                                                 gl.error().message +
                                                 " (install mesa-vulkan-drivers or libosmesa6)");
}

}  // namespace rgbdcast
