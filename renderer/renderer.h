#pragma once
// The one rendering interface, header-only (the INTERFACE target rgbdcast_renderer_api). Backends
// (renderer/vulkan/, renderer/osmesa/) implement it; create_renderer() (renderer/create_renderer.h, in the library
// rgbdcast_renderer) is the single place that chooses one. A Renderer is used by one thread at a time; scenes stay
// resident on the device between renders (upload once, render many views).
#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "scene/camera.h"
#include "scene/image.h"
#include "scene/result.h"
#include "scene/scene.h"

namespace rgbdcast {

enum class RenderMode { kMesh, kPoints };
enum class BackendChoice { kAuto, kVulkan, kOsmesa };

inline const char* to_string(RenderMode mode) { return mode == RenderMode::kMesh ? "mesh" : "points"; }

inline const char* to_string(BackendChoice choice) {
  switch (choice) {
    case BackendChoice::kAuto:
      return "auto";
    case BackendChoice::kVulkan:
      return "vulkan";
    case BackendChoice::kOsmesa:
      return "osmesa";
  }
  return "auto";
}

// "auto", "vulkan" or "osmesa" (for command lines); anything else is kInvalidArgument.
inline Result<BackendChoice> parse_backend_choice(const std::string& name) {
  if (name == "auto") return BackendChoice::kAuto;
  if (name == "vulkan") return BackendChoice::kVulkan;
  if (name == "osmesa") return BackendChoice::kOsmesa;
  return make_error(ErrorCode::kInvalidArgument, "unknown backend '" + name + "' (auto, vulkan or osmesa)");
}

struct RenderOptions {
  RenderMode mode = RenderMode::kMesh;
  float point_size_px = 1.0f;  // splat edge length in pixels, points mode
  std::array<std::uint8_t, 3> background{0, 0, 0};
  bool want_depth = false;  // read back depth too (for evaluation)
  // A view drawn in batches, whose scenes do not fit the device together (a full-detail view of a long mission):
  // keep_targets draws over the colour and depth that the previous render_scenes() call left, instead of clearing
  // them; that call must have had the same image size (else kInvalidArgument). read_back = false draws only: the
  // result's images stay empty (every batch but a view's last).
  bool keep_targets = false;
  bool read_back = true;
};

struct RenderTimings {
  double render_ms = 0.0;    // command submission to GPU idle
  double readback_ms = 0.0;  // copying the image(s) to host memory
};

struct RenderResult {
  Image color;                 // RGBA8, alpha 255 where something was drawn, 0 on background
  std::vector<float> depth_m;  // width*height metres along the camera z axis, 0 on background; empty unless asked
  RenderTimings timings;
};

using ResidentSceneId = std::uint64_t;

class Renderer {
 public:
  virtual ~Renderer() = default;
  virtual std::string backend() const = 0;  // "vulkan" or "osmesa"
  virtual std::string device() const = 0;   // the device or renderer string, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)"
  // Copies a scene to the device. Fails on an empty scene (no triangles and no points). upload_ms is reported.
  virtual Result<ResidentSceneId> upload(const Scene& scene, double* upload_ms = nullptr) = 0;
  // Adds the nodes of `scene` to the resident scene `id`, uploading only them: a live mission grows by one keyframe
  // without the rest going to the device again. The scene's cameras are not kept (the caller holds them). Fails like
  // upload() (an empty scene, bad data), and with kNotFound on an unknown id; on failure the resident scene is as it
  // was. Backends without it return kUnavailable (the caller then uploads the whole scene again).
  virtual Status append(ResidentSceneId id, const Scene& scene, double* upload_ms = nullptr) {
    (void)id, (void)scene, (void)upload_ms;
    return make_error(ErrorCode::kUnavailable, backend() + ": appending to a resident scene is not supported");
  }
  virtual void release(ResidentSceneId id) = 0;
  // Renders resident scenes together, in one image with one depth buffer (a tiled mission draws the tiles a view
  // selected, each resident on its own). Mesh mode draws each node's triangles, and the points of nodes without
  // triangles. Points mode draws each node's points, or the mesh vertices when a node has no points.
  // Fails on an unknown id (nothing is drawn), a camera with non-finite values or a size outside 1..kMaxImageSize.
  // An empty list draws the background.
  virtual Result<RenderResult> render_scenes(std::span<const ResidentSceneId> ids, const ViewCamera& camera,
                                             const RenderOptions& options) = 0;
  // One resident scene.
  Result<RenderResult> render(ResidentSceneId id, const ViewCamera& camera, const RenderOptions& options) {
    return render_scenes(std::span<const ResidentSceneId>(&id, 1), camera, options);
  }
  // Vulkan with validation on (RendererConfig::vulkan_validation): validation errors reported so far. 0 otherwise.
  virtual int validation_errors() const { return 0; }
};

}  // namespace rgbdcast
