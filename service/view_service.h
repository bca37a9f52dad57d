#pragma once
// The HTTP view service behind `rgbdcast serve`: scenes in (GLB or an RGB-D frame), operator views and GLBs out.
// Routes and their errors are documented in service/openapi.yaml. Contract: every error is a JSON body
// {"error", "detail"}; no exception leaves a handler; a body over max_body_bytes is 413 before it is processed;
// renders beyond the queue are 503 with Retry-After. httplib.h is included only by view_service.cpp (it must be
// compiled with the flags the library was built with, see ../shared/STACK.md).
#include <cstddef>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "renderer/renderer.h"
#include "scene/result.h"

namespace rgbdcast::service {

struct ServeOptions {
  std::string data_dir = "rgbdcast-data";
  std::string bind = "127.0.0.1";  // loopback unless asked
  int port = 8080;                 // 0: any free port (the bound port is printed)
  int threads = 16;                // HTTP worker threads (each keep-alive connection holds one while active)
  size_t max_body_bytes = 64u << 20;
  BackendChoice backend = BackendChoice::kAuto;
  int renderers = 2;               // renderer instances: two overlap one view's render with another's readback and
                                   // encoding (bench/load.sh on 2 cores: 64 -> 80 views/s on lavapipe)
  int render_queue = 32;           // views waiting beyond those rendering; more get 503
};

class ViewService {
 public:
  // Opens the store, creates the renderers, binds the socket. Errors: kIo (data dir, bind), kUnavailable (no
  // renderer), kInvalidArgument (options).
  static Result<std::unique_ptr<ViewService>> create(const ServeOptions& options);
  ~ViewService();

  int port() const;                  // the bound port
  std::string backend() const;       // "vulkan" or "osmesa"
  std::string backend_reason() const;
  std::string device() const;
  size_t scene_count() const;
  // Stores a GLB file as if it had been POSTed (same checks); a file whose bytes are already stored is not stored
  // twice (the existing scene is returned), so importing at every start is harmless.
  Result<nlohmann::json> import_glb_file(const std::string& path);
  // Serves until stop() is called (from another thread). Returns an error if the listener failed.
  Status run();
  void stop();

 private:
  struct Impl;
  explicit ViewService(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// The operator page served at GET / (HTML with inline JS), embedded at build time from service/page/index.html.
const std::string& operator_page_html();

}  // namespace rgbdcast::service
