#pragma once
// The HTTP view service behind `rgbdcast serve`: scenes in (GLB or an RGB-D frame), operator views and GLBs out.
// Routes and their errors are documented in service/openapi.yaml. Contract: every error is a JSON body
// {"error", "detail"}; no exception leaves a handler; a body over max_body_bytes is 413 before it is processed;
// renders beyond the queue are 503 with Retry-After. This header does not include httplib.h: the route files do
// (connection_gate.h, http_reply.h, upload_body.h and model_flavors.cpp, and the .cpp files that include those
// headers), and only targets that link PkgConfig::HTTPLIB may compile them, because that target carries the
// CPPHTTPLIB_*_SUPPORT definitions the library was built with; without them the classes' layout differs from the
// library's and the server crashes.
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "renderer/renderer.h"
#include "scene/result.h"

namespace rgbdcast::service {

struct ServeOptions {
  std::string data_dir = "rgbdcast-data";
  // Where scenes and missions live: empty (or "directory") for the folder data_dir, or a libpq URI
  // (postgresql://...) for a database shared by replicas (pgstore/), tiles included; data_dir then holds this
  // replica's copy of the tiles it served.
  std::string store;
  std::string replica;   // this replica's name, sent as X-Rgbdcast-Replica on every response; empty: the host name
  double drain_s = 0.0;  // on stop(): seconds /readyz answers 503 while requests are still served, then the stop
  std::string bind = "127.0.0.1";     // loopback unless asked
  int port = 8080;                    // 0: any free port (the bound port is printed)
  int threads = 32;                   // HTTP worker threads; a connection holds one only while a request is served
                                      // (service/connection_gate.h). Must exceed renderers + render_queue + max_uploads
                                      // + max_event_streams so that the queues, not the threads, fill up first.
  size_t max_body_bytes = 64u << 20;  // bytes received, after any Content-Encoding is inflated
  BackendChoice backend = BackendChoice::kAuto;
  int renderers = 2;         // renderer instances: two overlap one view's render with another's readback and
                             // encoding (bench/load.sh on 2 cores: 64 -> 80 views/s on lavapipe)
  int render_queue = 16;     // views waiting beyond those rendering; more get 503
  size_t resident_mb = 512;  // missions' tiles and keyframes resident on the renderers, all together (MiB;
                             // least recently used evicted: service/render_pool.h)
  bool supersede = true;     // newer keyframes supersede the older surface they cover in the tiles (tiles/tile_cover.h)
  // A mission's model.glb without max-error decodes every keyframe in memory (a few MB each at their peak): longer
  // missions are answered 409, pointing to the export from their tiles (?max-error=0 streams full detail from disk).
  int max_model_keyframes = 300;
  int reducers = 1;        // frame reductions at once
  int reduce_threads = 0;  // OpenMP threads per reduction (ReductionParams::threads); 0 = max(1, cores /
                           // reducers), so reductions at once never ask for more threads than cores
  int reduce_queue = 2;    // frame uploads waiting for a reducer; more get 503
  int max_uploads = 8;     // request bodies being received at once; more get 503
  int max_frame_width = 1920, max_frame_height = 1080;  // multipart frames, checked from the image headers
  // Access control: a token makes POST and DELETE need "Authorization: Bearer <token>". Binding to a non-loopback
  // address without a token is refused unless insecure_no_auth.
  std::string token;
  bool insecure_no_auth = false;
  std::vector<std::string> allow_origins;  // extra origins (and their hosts) accepted besides the server's own
  double header_timeout_s = 5.0;           // a new connection has this long to send its request headers
  double idle_timeout_s = 5.0;             // keep-alive connections close after this long without a request
  int max_connections = 512;
  // Live missions' event streams (service/mission_routes.h): each open stream holds an HTTP thread.
  int max_event_streams = 4;
  double event_stream_max_s = 300.0;  // an SSE response ends after this long; EventSource reconnects
  double keep_alive_s = 15.0;         // ": keep-alive" after this long without an event
  // The operator page's npm modules (three.js, 3DTilesRendererJS: service/web_assets.h); "" = the build's default,
  // tools/node_modules of the source tree. Without them the page renders on the server.
  std::string web_modules_dir;
};

class ViewService {
 public:
  // Opens the store, creates the renderers, binds the socket. Errors: kIo (data dir, bind), kUnavailable (no
  // renderer), kInvalidArgument (options).
  static Result<std::unique_ptr<ViewService>> create(const ServeOptions& options);
  ~ViewService();

  int port() const;             // the bound port
  std::string url() const;      // http://<bind address>:<port>
  std::string backend() const;  // "vulkan" or "osmesa"
  std::string backend_reason() const;
  std::string device() const;
  std::string web_modules_dir() const;  // the folder the page's modules come from
  bool web_modules_present() const;     // whether three.js and 3DTilesRendererJS are in it
  size_t scene_count() const;
  // Stores a GLB file as if it had been POSTed (same checks); a file whose bytes are already stored is not stored
  // twice (the existing scene is returned), so importing at every start is harmless.
  Result<nlohmann::json> import_glb_file(const std::string& path);
  // Serves until stop() is called (from another thread). Returns an error if the listener failed.
  Status run();
  // Drains, then stops: /readyz answers 503 from now on (a balancer sends new work elsewhere), requests are still
  // served for drain_s, then the listener closes and the requests under way finish.
  void stop();
  const std::string& replica() const;

 private:
  struct Impl;
  explicit ViewService(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// The operator page served at GET / (HTML with inline JS), embedded at build time from service/page/index.html.
const std::string& operator_page_html();

}  // namespace rgbdcast::service
